"""``flexlift rig``: a stand-in for the lift on an MQTT broker (docs/reference/live.md#the-rig):
the scenario's plant simulated in real time or ``--speed K`` times faster, publishing each
sensor of its ``sensors:`` section at its rate with its noise, latency and dropouts, obeying
the valve commands it receives, running the scenario's faults without telling anyone. It
ends when the simulated run ends (``simulation.duration_s``, or the target held), at
``--wall-limit``, or on SIGINT; then it prints what happened to the plant.

Exit codes: 0, or 2 for bad input (also when the broker refuses the account, or its TLS
certificate is not trusted, at the start).
"""

from __future__ import annotations

import argparse
import math
import sys
import threading

from flexlift.cli._common import add_scenario_arg, help_text, positive_float, scenario_from
from flexlift.cli.broker import account_from, add_account_args


def add_parser(sub) -> None:
    p = sub.add_parser("rig", help="a simulated lift on MQTT: sensors out, valve commands in",
                       description=help_text(__doc__))
    add_scenario_arg(p)
    p.add_argument("--broker", required=True,
                   help="mqtt://HOST[:PORT], or mqtts://HOST[:PORT] over TLS (--tls-ca)")
    p.add_argument("--speed", type=positive_float("--speed"), default=1.0,
                   help="times real time (default 1)")
    p.add_argument("--lift", default=None, help="the lift's name in the topics "
                   "(default: the scenario's)")
    add_account_args(p)
    p.add_argument("--wall-limit", type=positive_float("--wall-limit"), default=math.inf,
                   help="end after this many seconds of this machine's clock")
    p.set_defaults(func=_main)


def _main(args: argparse.Namespace) -> int:
    from flexlift.live.broker import parse_broker
    from flexlift.live.messages import lift_name
    from flexlift.live.mqtt import Link, start_or_refuse
    from flexlift.live.rig import Rig

    address = parse_broker(args.broker)
    account = account_from(args, address)
    scenario = scenario_from(args)
    lift = lift_name(args.lift or scenario.name)
    link = Link(address, (), "rig", **account)
    rig = Rig(scenario, link, lift, speed=args.speed)
    link.topics = [rig.command_topics()]
    if not start_or_refuse(link):  # refused (a wrong account, an untrusted broker): exit 2
        sys.stdout.write(f"flexlift rig: broker at {address.url} not answering yet "
                         f"({link.failure}): reconnecting\n")
    sys.stdout.write(f"flexlift rig: lift {lift} on {address.url} at {args.speed:g}x, "
                     f"{len(rig.tap.sensors)} sensors\n")
    sys.stdout.flush()
    stop = threading.Event()
    try:
        rig.run(stop, args.wall_limit)
    except KeyboardInterrupt:
        stop.set()
        rig.result = rig.ascent.finish(summary_only=True)
    finally:
        link.stop()
    h = rig.result.headline
    sys.stdout.write(
        f"flexlift rig: the plant: {rig.result.outcome.get('kind')}, max ascent velocity "
        f"{h['max_ascent_velocity_ms']} m/s, max pitch {h['max_pitch_deg']} deg; "
        f"{rig.published} readings published, {rig.applied} commands applied "
        f"({rig.repeats} repeats dropped, {rig.tally.total} malformed), "
        f"largest lag {rig.lag_s:.2f} s\n")
    return 0
