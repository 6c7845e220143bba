"""A real lift's broker (issue 42's deployment): ``flexlift broker`` writes Mosquitto's
configuration (accounts with hashed passwords, an ACL), Debian's Mosquitto runs it, and
through it only the master moves a valve, each sensor node publishes only its own readings,
and a wrong password, an unknown user or no account at all is refused. Its TLS listener,
and flexlift live and rig running the lift through it on their accounts: test_broker_tls.py."""

import json
import os
import pwd
import stat
import subprocess
import sys
import time

import pytest
from live_helpers import MOSQUITTO, Mosquitto, free_port, wait_until

from flexlift.cli import main
from flexlift.live.broker import BrokerAddress
from flexlift.live.deploy import (
    ACL,
    CONF,
    PASSWD,
    PASSWORDS,
    Tls,
    acl_text,
    mosquitto_conf,
    password_hash,
    rules,
)
from flexlift.live.messages import command_topic, sensor_topic
from flexlift.live.mqtt import QOS_COMMAND, Link

TANKER_BAGS = [f"bag_{i}" for i in range(1, 8)]
#: longest wait for a connection or a delivery [s]; then how long a forged message may lag
WAIT_S, LAG_S = 5.0, 0.5

needs_mosquitto = pytest.mark.skipif(not os.access(MOSQUITTO, os.X_OK),
                                     reason="Debian's mosquitto is not installed")


@pytest.fixture
def lift_broker(tmp_path):
    """``flexlift broker tanker --lift tk`` written and run by Mosquitto on a free port;
    yields (address, the folder written); stopped by its PID."""
    if not os.access(MOSQUITTO, os.X_OK):
        pytest.skip("Debian's mosquitto is not installed (.ci/run installs it)")
    port, out = free_port(), tmp_path / "broker"
    me = pwd.getpwuid(os.getuid()).pw_name  # as root, Mosquitto would become "mosquitto"
    assert main(["broker", "tanker", "--lift", "tk", "--out", str(out), "--port", str(port),
                 "--run-as", me]) == 0
    broker = Mosquitto(tmp_path, port, conf=out / CONF).start()
    try:
        yield BrokerAddress("127.0.0.1", port), out
    finally:
        broker.stop()


def _password(out, user):
    return (out / PASSWORDS / user).read_text().strip()


def _link(address, out, user, topics=()):
    return Link(address, topics, user, user, _password(out, user))


def _received(link, into: list) -> list:
    into += [(topic, json.loads(payload)) for _, topic, payload in link.drain()]
    return into


def test_the_files_written_hold_no_clear_password_and_refuse_anonymous(tmp_path):
    out = tmp_path / "b"
    assert main(["broker", "tanker", "--lift", "tk", "--out", str(out)]) == 0
    users = sorted(p.name for p in (out / PASSWORDS).iterdir())
    assert users == sorted(["master", "rig", "hull", *TANKER_BAGS])
    passwd = (out / PASSWD).read_text()
    for user in users:
        secret = (out / PASSWORDS / user)
        assert stat.S_IMODE(secret.stat().st_mode) == 0o600
        assert secret.read_text().strip() not in passwd
        assert f"\n{user}:$7$101$" in "\n" + passwd
    assert stat.S_IMODE((out / PASSWD).stat().st_mode) == 0o600
    conf = (out / CONF).read_text()
    assert "allow_anonymous false" in conf and f"acl_file {out}/{ACL}" in conf
    assert "listener 1883 127.0.0.1" in conf and conf.count("\nlistener ") == 1
    assert stat.S_IMODE((out / PASSWORDS).stat().st_mode) == 0o700
    before = _password(out, "master")
    assert main(["broker", "tanker", "--lift", "tk", "--out", str(out)]) == 0  # its own folder
    assert _password(out, "master") != before  # new every time


def test_the_acl_grants_each_role_its_own_topics_only():
    acl = acl_text(rules("tk", ["bag_1"]))
    blocks = {b.split("\n")[0]: set(b.split("\n")[1:]) for b in acl.strip().split("\n\n")[1:]}
    assert blocks == {
        "user master": {"topic write flexlift/tk/command/#", "topic read flexlift/tk/sensor/#"},
        "user rig": {"topic write flexlift/tk/sensor/#", "topic read flexlift/tk/command/#"},
        "user bag_1": {"topic write flexlift/tk/sensor/bag_1/#",
                       "topic read flexlift/tk/command/bag_1/#"},
        "user hull": {"topic write flexlift/tk/sensor/hull/#"}}


@pytest.mark.parametrize("bags", [["bag 1"], ["bag/1"], ["bag#"], ["master"], ["hull"], [""]])
def test_a_bag_name_that_cannot_be_an_account_is_refused(bags):
    from flexlift.errors import InputError

    with pytest.raises(InputError, match="bag name"):
        rules("tk", bags)


def test_the_password_hash_is_mosquittos_pbkdf2_sha512():
    import base64
    import hashlib

    salt = bytes(range(12))
    text = password_hash("s3cret", salt)
    _, kind, rounds, salt64, digest64 = text.split("$")
    assert (kind, rounds, base64.b64decode(salt64)) == ("7", "101", salt)
    assert base64.b64decode(digest64) == hashlib.pbkdf2_hmac("sha512", b"s3cret", salt, 101)


def test_the_tls_listener_text():
    """The network listener with TLS (its text; run by Mosquitto in test_broker_tls.py)."""
    conf = mosquitto_conf("/etc/flexlift", 1883, "0.0.0.0", tls=Tls("/c.pem", "/k.pem", "/ca.pem"))
    tail = conf.split("listener 1883 127.0.0.1\n")[1]
    assert tail.split() == ["listener", "8883", "0.0.0.0", "certfile", "/c.pem", "keyfile",
                            "/k.pem", "cafile", "/ca.pem", "tls_version", "tlsv1.2"]
    plain = mosquitto_conf("/etc/flexlift", 1883, "0.0.0.0")
    assert "listener 1884 0.0.0.0" in plain and "certfile" not in plain


@pytest.mark.parametrize("args, field", [
    (["--network-port", "70000"], "--network-port"),
    (["--tls-cert", "c.pem", "--listen", "0.0.0.0"], "--tls-cert/--tls-key/--tls-ca"),
    (["--port", "0"], "--port"),
    (["--run-as", "x\nallow_anonymous true"], "--run-as"),
    (["--listen", "0.0.0.0 1883\nallow_anonymous true"], "--listen"),
])
def test_broker_refuses_bad_options(tmp_path, capsys, args, field):
    assert main(["broker", "tanker", "--out", str(tmp_path / "o"), *args]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and field in err and "Traceback" not in err
    assert not (tmp_path / "o").exists()


def test_live_refuses_a_half_account(tmp_path, capsys):
    out = str(tmp_path / "o")
    assert main(["live", "tanker", "--out", out, "--broker", "mqtt://127.0.0.1:1",
                 "--user", "master"]) == 2
    assert main(["live", "tanker", "--out", out, "--broker", "mqtt://127.0.0.1:1",
                 "--user", "master", "--password-file", str(tmp_path / "none")]) == 2
    assert main(["live", "tanker", "--out", out, "--user", "master", "--password-file",
                 __file__]) == 2  # an account needs a --broker
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 3 and "--password-file" in lines[0] and "--password-file" in lines[1]


@needs_mosquitto
def test_only_the_master_moves_a_valve_and_each_node_speaks_for_itself(lift_broker):
    address, out = lift_broker
    master = _link(address, out, "master", ["flexlift/tk/sensor/#"])
    rig = _link(address, out, "rig", ["flexlift/tk/command/#"])
    bag_1 = _link(address, out, "bag_1", ["flexlift/tk/command/#"])
    hull = _link(address, out, "hull", ["flexlift/tk/#"])
    links = [master, rig, bag_1, hull]
    try:
        assert all(link.start(WAIT_S) for link in links), [link.refused for link in links]

        def send(link, topic, value, seq=None):
            body = {"time": 1.0, "value": value} | ({} if seq is None else {"seq": seq})
            info = link.publish(topic, json.dumps(body).encode(), QOS_COMMAND)
            info.wait_for_publish(WAIT_S)  # the broker has it (and may drop it)
            assert info.is_published()

        forged = [  # first: each would arrive before the genuine ones if delivered
            (bag_1, command_topic("tk", "bag_1", "fill"), 0.9),
            (bag_1, command_topic("tk", "bag_2", "purge"), 0.8),
            (hull, command_topic("tk", "bag_3", "fill"), 0.7),
            (rig, command_topic("tk", "bag_4", "fill"), 0.6),
            (bag_1, sensor_topic("tk", "bag_2", "depth"), 9.0),
            (master, sensor_topic("tk", "bag_5", "depth"), 8.0),
            (hull, sensor_topic("tk", "bag_6", "depth"), 7.0)]
        for seq, (link, topic, value) in enumerate(forged):
            send(link, topic, value, seq)
        send(bag_1, sensor_topic("tk", "bag_1", "depth"), 349.5)
        send(hull, sensor_topic("tk", "hull", "pitch"), 0.01)
        send(rig, sensor_topic("tk", "bag_7", "sling_force"), 4.2e5)
        send(master, command_topic("tk", "bag_1", "fill"), 0.12, seq=100)
        send(master, command_topic("tk", "bag_2", "purge"), 0.5, seq=101)
        at = {id(link): [] for link in links}
        assert wait_until(lambda: len(_received(master, at[id(master)])) >= 3
                          and len(_received(rig, at[id(rig)])) >= 2, WAIT_S)
        time.sleep(LAG_S)  # room for a forged message to come late
        got = {name: sorted((t, m["value"]) for t, m in _received(link, at[id(link)]))
               for name, link in zip(("master", "rig", "bag_1", "hull"), links)}
    finally:
        for link in links:
            link.stop()
    assert got["master"] == sorted([(sensor_topic("tk", "bag_1", "depth"), 349.5),
                                    (sensor_topic("tk", "hull", "pitch"), 0.01),
                                    (sensor_topic("tk", "bag_7", "sling_force"), 4.2e5)])
    assert got["rig"] == [(command_topic("tk", "bag_1", "fill"), 0.12),
                          (command_topic("tk", "bag_2", "purge"), 0.5)]
    assert got["bag_1"] == [(command_topic("tk", "bag_1", "fill"), 0.12)]  # its own valve only
    assert got["hull"] == []  # it may receive nothing


@needs_mosquitto
@pytest.mark.parametrize("user, password", [("master", "wrong"), ("bag_1", None),
                                            ("nobody", "x"), (None, None)])
def test_a_wrong_password_an_unknown_user_or_no_account_is_refused(lift_broker, user, password):
    address, out = lift_broker
    if password is None and user is not None:  # another account's password
        password = _password(out, "master")
    link = Link(address, ["flexlift/tk/sensor/#"], "intruder", user, password)
    try:
        began = time.monotonic()
        assert not link.start(WAIT_S)  # at once: refused, not waited out
        assert time.monotonic() - began < WAIT_S / 2
        assert link.refused == "Not authorized"
    finally:
        link.stop()


@needs_mosquitto
def test_live_refused_by_the_broker_says_it_and_exits_2(lift_broker, tmp_path):
    """A wrong password on the plain loopback listener: one line on stderr, exit 2, no
    output folder (over TLS, and for the rig: test_broker_tls.py)."""
    address, _ = lift_broker
    wrong = tmp_path / "wrong"
    wrong.write_text("not-the-password\n")
    proc = subprocess.run(
        [sys.executable, "-m", "flexlift", "live", "tanker", "--broker", address.url, "--lift",
         "tk", "--user", "master", "--password-file", str(wrong), "--out", str(tmp_path / "o"),
         "--until", "100", "--no-plan", "--no-dashboard", "--wall-limit", "20"],
        env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}, capture_output=True,
        text=True, timeout=240)
    assert proc.returncode == 2, (proc.stdout, proc.stderr[-2000:])
    assert proc.stderr.strip() == (
        f"flexlift live: error: --user: got 'master'; the broker at {address.url} refused this "
        "account (Not authorized): give the account and the password file flexlift broker "
        "wrote for it")
    assert not (tmp_path / "o").exists()
