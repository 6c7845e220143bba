"""An alarm of the fault detector: what failed, where, since when, how sure, and what a salvor
does about it (docs/theory/fault-detection.md#alarms)."""

from __future__ import annotations

from dataclasses import dataclass, field

#: every kind the detector names: the scenario's fault kinds (flexlift.scenario.schema)
KINDS = ("bag_rupture", "sling_break", "supply_failure", "sensor_drift", "sensor_stuck",
         "sensor_dropout", "dump_valve_stuck_closed", "fill_valve_stuck_open",
         "fill_valve_stuck_closed")

#: what each kind is, in a salvage master's words
WHAT = {
    "bag_rupture": "bag ruptured: its gas escapes, its lift is going",
    "sling_break": "sling broken: the bag no longer holds the hull",
    "supply_failure": "gas supply lost (or its fill valve stuck closed: the readings are the same)",
    "sensor_drift": "depth gauge drifting: its reading parts from the bag's load and the other gauges",
    "sensor_stuck": "instruments stuck: they repeat the same value exactly",
    "sensor_dropout": "instruments silent: no readings",
    "dump_valve_stuck_closed": "dump valve stuck closed: it stays shut when the bag must vent",
    "fill_valve_stuck_open": "fill valve stuck open: the bag fills at the full rate unasked",
    "fill_valve_stuck_closed": "fill valve stuck closed (or its supply lost: the readings are the same)",
}

#: what a salvor does about it
ADVICE = {
    "bag_rupture": "isolate the bag's supply and stop filling it; shift its load to the "
                   "neighbouring bags (raise their fill) and slow the ascent until the load "
                   "is balanced",
    "sling_break": "stop filling the loose bag and vent it (it rises free: clear the surface "
                   "above it); shift its load to the neighbouring bags and hold the ascent "
                   "until the hull is level",
    "supply_failure": "switch the bag to the standby supply or a spare line; meanwhile hold its "
                      "volume (no purge) and let the neighbours take any extra lift; if the "
                      "supply pressure is up at the manifold, the fill valve is stuck closed: "
                      "cycle it",
    "sensor_drift": "stop trusting the gauge: steer the bag on its load cell and the "
                    "neighbouring gauges, recalibrate or replace it at the next hold",
    "sensor_stuck": "stop trusting the bag's instruments: steer it on its neighbours' readings "
                    "and hold its fill; reset the bag's instrument unit",
    "sensor_dropout": "hold the bag's fill and purge as they are and steer on the neighbours "
                      "until its readings return; check the bag's telemetry link",
    "dump_valve_stuck_closed": "the bag cannot vent: slow the ascent, vent through its "
                               "standby or emergency purge, and reduce the neighbours' lift "
                               "before the surface",
    "fill_valve_stuck_open": "close the bag's isolation valve on the manifold and open its "
                             "purge; slow the ascent until the extra lift is vented",
    "fill_valve_stuck_closed": "cycle the fill valve; if it stays shut, fill through the "
                               "standby line and let the neighbours take the missing lift",
}


@dataclass(frozen=True)
class Alarm:
    """One named fault.

    Attributes
    ----------
    time_s : float
        When it was raised: the time [s since filling began] of the reading (or tick) that
        completed the evidence.
    kind : str
        One of :data:`KINDS`.
    bag : str
        The bag's name, or ``"hull"``.
    sensor : str or None
        The one sensor at fault (``"<bag>/<quantity>"``), None when the fault is the bag's
        (or all of its instruments).
    confidence : float
        0 .. 1: the probability, under the detector's own tests, that the fault is real and
        of this kind: the product over the tests that raised it of ``1 - p`` (``p`` each
        test's p-value: the chance that nothing is wrong and its statistic reached its value
        all the same), divided by the number of kinds the readings cannot tell apart
        (``1 + len(alternatives)``).
    message : str
        One line: what, where, since when.
    advice : str
        What a salvor does.
    onset_s : float
        The estimated time the fault began [s].
    alternatives : tuple of str
        Kinds that explain the readings as well (a lost supply and a fill valve stuck closed
        read the same).
    evidence : dict
        The tests' numbers (statistics, p-values), for the record.
    """

    time_s: float
    kind: str
    bag: str
    sensor: str | None
    confidence: float
    message: str
    advice: str
    onset_s: float
    alternatives: tuple[str, ...] = ()
    evidence: dict = field(default_factory=dict, compare=False)

    def to_dict(self) -> dict:
        """JSON-ready: the fields above."""
        return {"time_s": self.time_s, "kind": self.kind, "bag": self.bag,
                "sensor": self.sensor, "confidence": self.confidence,
                "message": self.message, "advice": self.advice, "onset_s": self.onset_s,
                "alternatives": list(self.alternatives), "evidence": dict(self.evidence)}


def make_alarm(time_s: float, kind: str, bag: str, sensor: str | None, p_values,
               onset_s: float, detail: str, alternatives: tuple[str, ...] = (),
               evidence: dict | None = None) -> Alarm:
    """An :class:`Alarm` with its confidence from the tests' ``p_values`` and its message
    (``detail``: the readings that show it, in a few words)."""
    real = 1.0
    for p in p_values:
        real *= 1.0 - min(max(float(p), 0.0), 1.0)
    confidence = real / (1 + len(alternatives))
    where = bag if sensor is None else sensor
    message = (f"{where}: {WHAT[kind]} since t = {onset_s:.0f} s ({detail}); "
               f"raised at t = {time_s:.0f} s")
    return Alarm(time_s, kind, bag, sensor, confidence, message, ADVICE[kind], onset_s,
                 alternatives, dict(evidence or {}))
