"""The lift's broker over TLS, run (issue 42's deployment): a throwaway CA and a certificate
for 127.0.0.1/localhost made by Debian's ``openssl``, ``flexlift broker --tls-cert/--tls-key
/--tls-ca`` written and run by Debian's Mosquitto on free loopback ports, and paho clients
(flexlift's :class:`~flexlift.live.mqtt.Link`) and the ``flexlift live``/``rig`` commands
through it: the CA's clients connect as their accounts, a client without TLS or trusting
another CA does not, the ACL holds over TLS, and the whole chain runs on it."""

import json
import os
import pwd
import re
import shutil
import signal
import subprocess
import sys
import time

import pytest
from live_helpers import MOSQUITTO, OPENSSL, Mosquitto, free_port, make_certificates, wait_until

from flexlift.cli import main
from flexlift.live.broker import BrokerAddress, parse_broker
from flexlift.live.deploy import CONF, PASSWORDS
from flexlift.live.messages import command_topic, sensor_topic
from flexlift.live.mqtt import QOS_COMMAND, Link

#: longest wait for a connection or a delivery [s]; how long a refused message may lag [s]
WAIT_S, LAG_S = 5.0, 0.5


@pytest.fixture(scope="module")
def certificates(tmp_path_factory):
    """The CA, the broker's certificate and key, and another CA (made once per module)."""
    if shutil.which("openssl") is None and not os.access(OPENSSL, os.X_OK):
        pytest.skip("Debian's openssl is not installed: no certificate can be made")
    return make_certificates(tmp_path_factory.mktemp("tls"))


def _run_broker(tmp_path, cert, key, ca):
    """``flexlift broker tanker --lift tk`` with a TLS listener (``--listen 127.0.0.1``)
    with ``cert`` and ``key``, started by Mosquitto: (the process, the TLS address, the
    loopback plain address, the folder written)."""
    if not os.access(MOSQUITTO, os.X_OK):
        pytest.skip("Debian's mosquitto is not installed (.ci/run installs it)")
    port, tls_port, out = free_port(), free_port(), tmp_path / "broker"
    me = pwd.getpwuid(os.getuid()).pw_name  # as root, Mosquitto would become "mosquitto"
    assert main(["broker", "tanker", "--lift", "tk", "--out", str(out), "--port", str(port),
                 "--listen", "127.0.0.1", "--network-port", str(tls_port), "--run-as", me,
                 "--tls-cert", str(cert), "--tls-key", str(key), "--tls-ca", str(ca)]) == 0
    broker = Mosquitto(tmp_path, port, conf=out / CONF, more_ports=(tls_port,)).start()
    return (broker, BrokerAddress("127.0.0.1", tls_port, tls=True),
            BrokerAddress("127.0.0.1", port), out)


@pytest.fixture
def tls_broker(tmp_path, certificates):
    """The lift's broker over TLS with a certificate for 127.0.0.1/localhost; yields (the
    TLS address, the loopback plain address, the folder written, the certificates);
    stopped by its PID."""
    broker, address, plain, out = _run_broker(tmp_path, certificates.cert, certificates.key,
                                              certificates.ca)
    try:
        yield address, plain, out, certificates
    finally:
        broker.stop()


def _password(out, user):
    return (out / PASSWORDS / user).read_text().strip()


def _tls_link(address, out, user, ca, topics=(), password=None):
    return Link(address, topics, user, user, password or _password(out, user), tls_ca=str(ca))


def test_the_broker_url_says_tls():
    assert parse_broker("mqtts://deck.local") == BrokerAddress("deck.local", 8883, True)
    assert parse_broker("mqtts://10.0.0.5:9000").url == "mqtts://10.0.0.5:9000"
    assert parse_broker("mqtt://10.0.0.5") == BrokerAddress("10.0.0.5", 1883, False)


@pytest.mark.parametrize("url", ["http://h", "mqtts://user:pw@h", "mqtt://h:0", "mqtt://h/x"])
def test_a_broker_url_that_is_not_one_is_refused(url):
    from flexlift.errors import InputError

    with pytest.raises(InputError, match="--broker"):
        parse_broker(url)


def test_the_two_listeners_cannot_share_a_port(tmp_path, capsys):
    """Mosquitto stops at once ("Address already in use") on such a configuration."""
    assert main(["broker", "tanker", "--out", str(tmp_path / "o"), "--port", "1884",
                 "--listen", "0.0.0.0", "--network-port", "1884"]) == 2
    err = capsys.readouterr().err.strip()
    assert "--network-port" in err and "\n" not in err and not (tmp_path / "o").exists()


def test_a_ca_is_for_a_tls_broker_and_must_be_a_certificate(tmp_path, capsys):
    out = str(tmp_path / "o")
    not_pem = tmp_path / "ca.pem"
    not_pem.write_text("not a certificate\n")
    assert main(["live", "tanker", "--out", out, "--broker", "mqtt://127.0.0.1:1",
                 "--tls-ca", str(not_pem)]) == 2  # a CA for a plain broker
    assert main(["rig", "tanker", "--broker", "mqtts://127.0.0.1:1", "--tls-ca",
                 str(tmp_path / "none.pem")]) == 2
    assert main(["rig", "tanker", "--broker", "mqtts://127.0.0.1:1", "--tls-ca",
                 str(not_pem)]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 3 and all("--tls-ca" in line for line in lines), lines
    assert "mqtts://" in lines[0] and "existing" in lines[1] and "NO_CERTIFICATE" in lines[2]
    assert not os.path.exists(out)


def test_a_client_trusting_the_ca_connects_over_tls_as_its_account(tls_broker):
    address, _, out, certs = tls_broker
    link = _tls_link(address, out, "master", certs.ca)
    wrong = _tls_link(address, out, "master", certs.ca, password="wrong")
    try:
        assert link.start(WAIT_S), (link.refused, link.failure)
        assert link.client.socket().version() in ("TLSv1.2", "TLSv1.3")  # TLS, not plain
        assert not wrong.start(WAIT_S) and wrong.refused == "Not authorized"
    finally:
        link.stop()
        wrong.stop()


def test_a_client_without_tls_on_the_tls_port_does_not_connect(tls_broker):
    address, _, out, _ = tls_broker
    plain = BrokerAddress(address.host, address.port)  # the TLS port, spoken to in clear
    link = Link(plain, (), "plain", "master", _password(out, "master"))
    try:
        assert not link.start(1.0)
        assert wait_until(lambda: link.failure is not None, WAIT_S)  # dropped, not answered
        assert "closed before the broker answered" in link.failure and "mqtts://" in link.failure
        assert not link.connected.is_set() and link.connects == 0
    finally:
        link.stop()


def test_a_client_trusting_another_ca_is_refused_at_once(tls_broker):
    address, _, out, certs = tls_broker
    link = _tls_link(address, out, "master", certs.other_ca)
    try:
        began = time.monotonic()
        assert not link.start(WAIT_S)
        assert time.monotonic() - began < WAIT_S / 2
        assert link.untrusted and "self-signed certificate in certificate chain" in link.refused
    finally:
        link.stop()


def test_a_certificate_for_another_host_is_refused(tmp_path, certificates):
    """Signed by the trusted CA, but naming only elsewhere.invalid: paho checks the name."""
    c = certificates
    broker, address, _, out = _run_broker(tmp_path, c.elsewhere_cert, c.elsewhere_key, c.ca)
    link = _tls_link(address, out, "master", c.ca)
    try:
        assert not link.start(WAIT_S)
        assert link.untrusted and "certificate is not valid for '127.0.0.1'" in link.refused
    finally:
        link.stop()
        broker.stop()


def test_tls_to_the_plain_listener_does_not_connect(tls_broker):
    _, plain, out, certs = tls_broker
    link = _tls_link(BrokerAddress(plain.host, plain.port, tls=True), out, "master", certs.ca)
    try:
        assert not link.start(1.0) and link.refused is None
        assert wait_until(lambda: link.failure is not None, WAIT_S), link.failure
    finally:
        link.stop()


def test_the_acl_holds_over_tls(tls_broker):
    address, _, out, certs = tls_broker
    links = {user: _tls_link(address, out, user, certs.ca, topics)
             for user, topics in (("master", ["flexlift/tk/sensor/#"]),
                                  ("rig", ["flexlift/tk/command/#"]),
                                  ("bag_1", ["flexlift/tk/command/#"]))}
    try:
        assert all(link.start(WAIT_S) for link in links.values())

        def send(user, topic, value, seq):
            body = json.dumps({"time": 1.0, "value": value, "seq": seq}).encode()
            info = links[user].publish(topic, body, QOS_COMMAND)
            info.wait_for_publish(WAIT_S)
            assert info.is_published()
        send("bag_1", command_topic("tk", "bag_2", "fill"), 0.9, 1)  # forged: dropped
        send("rig", command_topic("tk", "bag_1", "fill"), 0.8, 2)  # forged: dropped
        send("bag_1", sensor_topic("tk", "bag_2", "depth"), 9.0, 3)  # another bag's: dropped
        send("bag_1", sensor_topic("tk", "bag_1", "depth"), 349.5, 4)
        send("master", command_topic("tk", "bag_1", "fill"), 0.12, 5)
        got = {user: [] for user in links}

        def drained():
            for user, link in links.items():
                got[user] += [(t, json.loads(p)["value"]) for _, t, p in link.drain()]
            return got["master"] and got["rig"] and got["bag_1"]
        assert wait_until(drained, WAIT_S)
        time.sleep(LAG_S)  # room for a refused message to come late
        drained()
    finally:
        for link in links.values():
            link.stop()
    assert got["master"] == [(sensor_topic("tk", "bag_1", "depth"), 349.5)]
    assert got["rig"] == got["bag_1"] == [(command_topic("tk", "bag_1", "fill"), 0.12)]


def _command(out, *args):
    """``python -m flexlift ...`` in a child process (its stdout and stderr piped)."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    return subprocess.Popen([sys.executable, "-m", "flexlift", *args], env=env, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)


@pytest.mark.parametrize("case", ["password", "ca"])
def test_live_and_rig_refused_say_it_in_one_line_and_exit_2(tls_broker, tmp_path, case):
    """A wrong password, or a CA that did not sign the broker's certificate: one line on
    stderr naming the option, exit 2, nothing written, the password in no output."""
    address, _, out, certs = tls_broker
    wrong = tmp_path / "wrong"
    wrong.write_text("not-the-password\n")
    password, ca = (wrong, certs.ca) if case == "password" else (
        out / PASSWORDS / "master", certs.other_ca)
    common = ["--broker", address.url, "--lift", "tk", "--tls-ca", str(ca), "--password-file",
              str(password), "--wall-limit", "20"]
    live = _command(out, "live", "tanker", *common, "--user", "master", "--out",
                    str(tmp_path / "o"), "--until", "100", "--no-plan", "--no-dashboard")
    rig = _command(out, "rig", "tanker", *common, "--user", "rig")
    results = []
    for proc in (live, rig):
        try:
            stdout, stderr = proc.communicate(timeout=60)
            results.append((proc.returncode, stdout, stderr))
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.communicate(timeout=10)
    field = "--user" if case == "password" else "--tls-ca"
    for (code, stdout, stderr), user in zip(results, ("master", "rig")):
        assert code == 2, (stdout, stderr[-2000:])
        lines = stderr.strip().splitlines()
        assert len(lines) == 1 and "Traceback" not in stderr, stderr[-2000:]
        assert f"error: {field}: got" in lines[0] and address.url in lines[0]
        assert ("Not authorized" if case == "password" else "not trusted") in lines[0]
        assert _password(out, user) not in stdout + stderr
    assert not (tmp_path / "o").exists()


def test_live_and_rig_run_the_lift_over_tls_on_their_accounts(tls_broker, tmp_path):
    """``flexlift broker`` -> Mosquitto over TLS -> ``flexlift rig`` and ``flexlift live``,
    each on its own account and trusting the CA: the readings reach live, its commands
    reach the rig, and no password shows in any output or in the report."""
    pytest.importorskip("flexlift.sensors.tap")
    from test_live import _scenario_file

    address, _, out, certs = tls_broker
    scenario = str(_scenario_file(tmp_path))

    def run(command, user, *more):
        return _command(out, command, scenario, "--broker", address.url, "--lift", "tk",
                        "--user", user, "--password-file", str(out / PASSWORDS / user),
                        "--tls-ca", str(certs.ca), *more)
    rig = run("rig", "rig", "--speed", "100", "--wall-limit", "120")
    live = run("live", "master", "--out", str(tmp_path / "live"), "--until", "200",
               "--no-plan", "--no-dashboard", "--wall-limit", "120")
    try:
        live_out, live_err = live.communicate(timeout=240)
        rig.send_signal(signal.SIGINT)  # it prints what it applied
        rig_out, rig_err = rig.communicate(timeout=30)
    finally:
        for proc in (live, rig):
            if proc.poll() is None:
                proc.kill()
                proc.communicate(timeout=10)
    assert live.returncode == 0, live_err[-2000:]
    assert f"master on {address.url}" in live_out
    report_text = (tmp_path / "live" / "report.json").read_text()
    report = json.loads(report_text)["lift"]
    assert report["ended"] == "time" and report["readings"] > 200 * 15 * 0.8
    assert report["commands"] > 0 and report["malformed"] == {}
    applied = re.search(r"(\d+) commands applied", rig_out)
    assert applied and int(applied.group(1)) > 0, (rig_out, rig_err[-2000:])
    everything = live_out + live_err + rig_out + rig_err + report_text + \
        (tmp_path / "live" / "report.md").read_text()
    log = b"".join(p.read_bytes() for p in (tmp_path / "live").iterdir() if p.is_file())
    for user in ("master", "rig"):
        assert _password(out, user) not in everything
        assert _password(out, user).encode() not in log  # nor in the log's database
