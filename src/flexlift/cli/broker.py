"""``flexlift broker``: write the Mosquitto configuration of a real lift's broker
(docs/reference/live.md#the-lifts-broker): an account per role (``master`` for flexlift
live, ``rig``, one per bag's sensor node and ``hull``), each with a new password (stored
hashed in ``passwd``; the clear one in ``passwords/<user>``, owner-only), and an ACL under
which only ``master`` may publish commands and each sensor node only its own readings.
Anonymous clients are refused. It listens on 127.0.0.1:``--port``; ``--listen ADDRESS``
adds a listener the sensor nodes reach, over TLS with ``--tls-cert/--tls-key/--tls-ca``.
Then: ``mosquitto -c OUT/mosquitto.conf``, and ``flexlift live ... --user master
--password-file OUT/passwords/master`` (from another machine: ``--broker mqtts://HOST:PORT
--tls-ca CA.pem``).

Exit codes: 0, or 2 for bad input.
"""

from __future__ import annotations

import argparse
import os
import sys

from flexlift.cli._common import add_scenario_arg, help_text, scenario_from
from flexlift.errors import InputError


def _port(name: str):
    def parse(text: str) -> int:
        try:
            port = int(text)
        except ValueError:
            port = -1
        if not 1 <= port <= 65535:
            raise argparse.ArgumentTypeError(f"{name}: {text!r} is not a port: give 1..65535")
        return port
    return parse


def add_parser(sub) -> None:
    p = sub.add_parser("broker", help="write a real lift's Mosquitto configuration: accounts "
                       "and ACL", description=help_text(__doc__))
    add_scenario_arg(p)
    p.add_argument("--out", required=True, help="folder of the configuration")
    p.add_argument("--lift", default=None, help="the lift's name in the topics "
                   "(default: the scenario's)")
    p.add_argument("--port", type=_port("--port"), default=1883,
                   help="the loopback listener's port (default 1883)")
    p.add_argument("--listen", default=None, metavar="ADDRESS",
                   help="also listen on ADDRESS for the sensor nodes (0.0.0.0: every interface)")
    p.add_argument("--network-port", type=_port("--network-port"), default=None,
                   help="that listener's port (default 8883 with TLS, else --port + 1)")
    p.add_argument("--run-as", default=None, metavar="USER",
                   help="the system user Mosquitto runs as (default its own: mosquitto); it "
                        "must own passwd and read acl")
    for name, what in (("cert", "the broker's certificate"), ("key", "its private key"),
                       ("ca", "the CA certificate the clients trust")):
        p.add_argument(f"--tls-{name}", default=None, metavar="PEM",
                       help=f"--listen over TLS: {what}")
    p.set_defaults(func=_main)


def add_account_args(p: argparse.ArgumentParser) -> None:
    """``--user``, ``--password-file`` and ``--tls-ca``: an account on a broker written by
    this command, and the CA its TLS listener's certificate is signed by."""
    p.add_argument("--user", default=None, help="the broker account (flexlift broker)")
    p.add_argument("--password-file", default=None, metavar="FILE",
                   help="its password (flexlift broker's passwords/USER)")
    p.add_argument("--tls-ca", default=None, metavar="PEM",
                   help="an mqtts:// broker: the CA certificate that signed its certificate "
                        "(default: the system's CAs)")


def account_from(args: argparse.Namespace, address) -> dict:
    """The account and TLS settings of ``add_account_args`` for the broker at ``address``
    (a BrokerAddress, None: the embedded broker) as ``Link``'s keywords ``username``,
    ``password``, ``tls_ca``; InputError if only one of user and password file is given, or
    a CA for a broker without TLS."""
    from flexlift.live.deploy import read_password

    if (args.user is None) != (args.password_file is None):
        given = "--user" if args.user is not None else "--password-file"
        raise InputError(given, args.user or args.password_file,
                         "give --user and --password-file together")
    if args.tls_ca is not None:
        if address is None or not address.tls:
            raise InputError("--tls-ca", args.tls_ca, "a CA is for a broker over TLS: give "
                             "--broker mqtts://HOST[:PORT]")
        if not os.path.isfile(args.tls_ca):
            raise InputError("--tls-ca", args.tls_ca, "give an existing PEM file")
    password = None if args.user is None else read_password(args.password_file)
    return {"username": args.user, "password": password, "tls_ca": args.tls_ca}


def _tls(args):
    from flexlift.live.deploy import Tls

    files = (args.tls_cert, args.tls_key, args.tls_ca)
    if all(f is None for f in files):
        return None
    if any(f is None for f in files) or args.listen is None:
        raise InputError("--tls-cert/--tls-key/--tls-ca", ", ".join(str(f) for f in files),
                         "give all three, with --listen")
    for option, path in zip(("--tls-cert", "--tls-key", "--tls-ca"), files):
        if not os.path.isfile(path):
            raise InputError(option, path, "give an existing PEM file")
    return Tls(*(os.path.abspath(f) for f in files))


def _main(args: argparse.Namespace) -> int:
    from flexlift.live.deploy import CONF, PASSWD, PASSWORDS, write_broker
    from flexlift.live.messages import lift_name
    from flexlift.loads.liftplan import plan_lift
    from flexlift.structure.hull import hull_from_scenario

    tls = _tls(args)
    scenario = scenario_from(args)
    lift = lift_name(args.lift or scenario.name)
    bags = [b.name for b in plan_lift(scenario, hull_from_scenario(scenario)).bags]
    files = write_broker(args.out, lift, bags, args.port, args.listen, args.network_port, tls,
                         args.run_as)
    out = os.path.join(args.out, CONF)
    sys.stdout.write(f"flexlift broker: lift {lift}, {len(files)} accounts (master, rig, "
                     f"hull and {len(bags)} bags), passwords in "
                     f"{os.path.join(args.out, PASSWORDS)}/; start it with: mosquitto -c {out}\n")
    # Mosquitto started as root reads these after becoming its user (tried: 2.0.11)
    readable = [os.path.join(args.out, PASSWD), *([tls.keyfile] if tls else [])]
    user = args.run_as or "mosquitto"
    sys.stdout.write(f"flexlift broker: started as root, Mosquitto reads {' and '.join(readable)}"
                     f" as {user}: first chown {user} {' '.join(readable)}\n")
    return 0
