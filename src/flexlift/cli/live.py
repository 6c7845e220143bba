"""``flexlift live``: run a lift over MQTT (docs/reference/live.md): read every sensor, run the
master controller (``--control master``: the coordinated laws fed from the network) or advise
(``--control advise``: the commands computed, shown and logged, none sent), raise alarms, log
everything to ``--out``/live.sqlite, and at the end write the report of the lift beside the
plan's simulation. ``--until arrived`` (default) or a time [s since filling began] ends it;
SIGINT ends it cleanly. Without ``--broker`` an embedded broker runs in the process;
``--rig`` runs the rig there too (``flexlift live tanker --rig``: the whole chain, one
command). While it runs it serves the dashboard (docs/guide/dashboard.md) on 127.0.0.1
(``--dashboard PORT``, default a free port, printed; ``--no-dashboard``: none).

Exit codes: 0 when it ended as asked (arrived, the time, or SIGINT), 1 when ``--until
arrived`` ended without arrival, 2 for bad input (also when the broker refuses the account,
or its TLS certificate is not trusted, at the start: nothing is written then).
"""

from __future__ import annotations

import argparse
import math
import sys
import threading
import time

from flexlift.cli._common import (
    add_scenario_arg,
    help_text,
    positive_float,
    positive_int,
    scenario_from,
)
from flexlift.cli.broker import account_from, add_account_args
from flexlift.errors import InputError


def _until(text: str):
    if text == "arrived":
        return text
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value) or value <= 0:
        raise InputError("--until", text, "use arrived or a time [s] > 0 since filling began")
    return value


def add_parser(sub) -> None:
    p = sub.add_parser("live", help="run a lift over MQTT: read, control, alarm, log",
                       description=help_text(__doc__))
    add_scenario_arg(p)
    p.add_argument("--broker", default=None, help="mqtt://HOST[:PORT], or mqtts://HOST[:PORT] "
                   "over TLS (--tls-ca) (default: embedded)")
    p.add_argument("--out", required=True, help="folder of the log and the report")
    p.add_argument("--control", choices=("master", "advise"), default="master")
    p.add_argument("--until", default="arrived", help="arrived (default) or a time [s]")
    p.add_argument("--rig", action="store_true", help="run the rig in this process too")
    add_account_args(p)
    p.add_argument("--dashboard", type=_port, default=0, metavar="PORT",
                   help="serve the dashboard on 127.0.0.1:PORT (default 0: a free port, "
                        "printed at the start)")
    p.add_argument("--no-dashboard", dest="dashboard", action="store_const", const=None,
                   help="serve no dashboard")
    p.add_argument("--speed", type=positive_float("--speed"), default=1.0,
                   help="--rig: the rig's speed, times real time (default 1)")
    p.add_argument("--lift", default=None, help="the lift's name in the topics "
                   "(default: the scenario's)")
    p.add_argument("--estimate", action="store_true",
                   help="run the estimator and fault detector on the readings too "
                        "(docs/reference/live.md#the-estimator)")
    p.add_argument("--members", type=positive_int("--members"), default=16,
                   help="--estimate: ensemble members (default 16)")
    p.add_argument("--forecast-every", type=positive_float("--forecast-every"),
                   default=120.0, help="--estimate: a forecast every this many seconds of "
                   "lift time (default 120)")
    p.add_argument("--no-plan", action="store_true",
                   help="leave the plan's simulation out of the report")
    p.add_argument("--wall-limit", type=positive_float("--wall-limit"), default=math.inf,
                   help="end after this many seconds of this machine's clock")
    p.set_defaults(func=_main)


def _say(line: str) -> None:
    sys.stdout.write(f"flexlift live: {line}\n")
    sys.stdout.flush()


def _port(text: str) -> int:
    """A TCP port 0..65535 (0: a free one), else one line and exit 2."""
    try:
        port = int(text)
    except ValueError:
        port = -1
    if not 0 <= port <= 65535:
        raise argparse.ArgumentTypeError(f"--dashboard: {text!r} is not a port: give 0..65535 "
                                         "(0: a free port)")
    return port


def _main(args: argparse.Namespace) -> int:
    from flexlift.live.broker import EmbeddedBroker, parse_broker
    from flexlift.live.messages import lift_name
    from flexlift.live.run import live_folder

    until = _until(args.until)
    if args.estimate:  # before anything is written: --members 1 is refused here
        _settings(args).check()
    address = parse_broker(args.broker) if args.broker else None
    args.account = account_from(args, address)
    if args.account["username"] is not None and (address is None or args.rig):
        raise InputError("--user", args.user, "an account is for a --broker, without --rig "
                         "(the embedded broker has none; run flexlift rig with its own)")
    scenario = scenario_from(args)
    lift = lift_name(args.lift or scenario.name)
    board = _dashboard(args.dashboard)  # before anything is written: a taken port is refused
    embedded = link = None
    try:
        if address is None:
            embedded = EmbeddedBroker().start()
            address = embedded.address
            _say(f"embedded broker on {address.url}")
        link = _connect(args, lift, address)  # a refusal: exit 2, nothing written
        with live_folder(args.out, lift) as (folder, log):
            outcome, summary = _run(args, scenario, lift, link, log, until, folder, board)
    finally:
        if link is not None:
            link.stop()
        if board is not None:
            board.stop()
        if embedded is not None:
            embedded.stop()
    when = (f"at t = {outcome.t_end:.1f} s" if math.isfinite(outcome.t_end)
            else "before any reading came")
    _say(f"ended: {outcome.reason} {when}; report in {args.out}/report.md")
    return 1 if until == "arrived" and outcome.reason != "arrived" and \
        outcome.reason != "interrupted" else 0


def _dashboard(port: int | None):
    """The dashboard started on 127.0.0.1:``port`` (None: none); InputError if it cannot."""
    if port is None:
        return None
    from flexlift.live.dashboard import Dashboard

    board = Dashboard(port=port)
    try:
        _say(f"dashboard on {board.start()}")
    except RuntimeError:
        raise InputError("--dashboard", str(port), "that port cannot be served on 127.0.0.1 "
                         "(taken?): give another, 0 for a free one, or --no-dashboard") from None
    return board


def _connect(args, lift: str, address):
    """live's link to the broker, started: InputError if the broker refuses it; said if it
    does not answer yet (it keeps trying)."""
    from flexlift.live.mqtt import Link, start_or_refuse

    link = Link(address, [f"flexlift/{lift}/sensor/#"], "live", **args.account)
    # a broker not answering is waited for at most 10 s, and never past the wall limit
    if not start_or_refuse(link, min(10.0, args.wall_limit)):
        _say(f"broker at {address.url} not answering yet ({link.failure}): waiting "
             "(reconnecting)")
    return link


def _run(args, scenario, lift, link, log, until, folder, board):
    from flexlift.live.master import Master
    from flexlift.live.mqtt import Link
    from flexlift.live.run import finish_report
    from flexlift.live.session import Live

    master = Master(scenario)
    rig_thread, rig, address = None, None, link.address
    if args.rig:
        from flexlift.live.rig import Rig

        rig = Rig(scenario, Link(address, (), "rig", tls_ca=args.account["tls_ca"]), lift,
                  speed=args.speed)
        rig.link.topics = [rig.command_topics()]
    live = Live(scenario, link, log, lift, args.control, _say,
                rate=args.speed if args.rig else None, periods=rig and rig.periods(),
                master=master)
    live.dashboard = board
    live.estimate = _estimator(args, scenario, master)
    stop, rig_done = threading.Event(), threading.Event()
    if rig is not None:
        rig.link.start()
        rig_thread = threading.Thread(target=_rig_then_say, args=(rig, stop, rig_done),
                                      name="flexlift-rig", daemon=True)
        rig_thread.start()
    _say(f"{args.control} on {address.url}, lift {lift}: {len(master.bags)} controlled bags")
    try:
        outcome = live.run(until, stop, epoch=time.time(), wall_limit=args.wall_limit,
                           source_ended=rig_done if rig is not None else None)
    finally:
        stop.set()
        if rig_thread is not None:
            rig_thread.join(10)
            rig.link.stop()
    estimate = None
    if live.estimate is not None:
        live.estimate.stop()
        estimate = live.estimate.summary()
        _say_estimate(estimate)
    summary = finish_report(folder, scenario, outcome, lift, args.control, not args.no_plan,
                            rig=rig, estimate=estimate)
    return outcome, summary


def _estimator(args, scenario, master):
    """The estimator started on the master's plant (``--estimate``), else None."""
    if not args.estimate:
        return None
    from flexlift.live.estimate import LiveEstimate

    settings = _settings(args)
    est = LiveEstimate(scenario, settings, plant=master.plant,
                       commanded=args.control == "master",
                       rate=args.speed if args.rig else 1.0).start()
    _say(f"estimator: {args.members} members, a forecast every {args.forecast_every:g} s")
    return est


def _settings(args):
    from flexlift.estimate.watch import Settings

    return Settings(members=args.members, forecast_every_s=args.forecast_every)


def _say_estimate(s: dict) -> None:
    f = s["forecasts"][-1] if s["forecasts"] else None
    text = (f"estimator: {len(s['alarms'])} alarms, estimated to t = "
            f"{s['estimated_to_s'] if s['estimated_to_s'] is not None else '-'} s "
            f"({s['behind_s'] if s['behind_s'] is not None else '-'} s behind the readings)")
    if f is not None and f["arrival_time_s"]:
        a = f["arrival_time_s"]
        text += (f"; forecast at {f['time_s']:.0f} s: arrival {a['p50']:.0f} s "
                 f"({a['p5']:.0f}-{a['p95']:.0f}), P(unsafe) {f['p_unsafe']:.2f}")
    if s["error"]:
        text += f"; the estimator stopped: {s['error']}"
    _say(text)


def _rig_then_say(rig, stop: threading.Event, done: threading.Event) -> None:
    """The rig's run (``--rig``), ``done`` set as soon as its plant has ended (before its
    result is made): no reading will come again and live ends too, on the readings sent
    (not waiting for an arrival that cannot come, nor taking them for a silent network);
    set too if the rig fails, so that live ends then."""
    try:
        rig.run(stop, ended=done)
    finally:
        done.set()
