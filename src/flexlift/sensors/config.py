"""The lift's sensors, one by one, from the scenario's ``sensors:`` section and the plant's
bag names (docs/reference/sensor-log.md)."""

from __future__ import annotations

from dataclasses import dataclass

from flexlift.errors import InputError
from flexlift.scenario.sensors import DEFAULT_FOR_LOG, HULL_QUANTITIES, QUANTITIES, Sensors

#: the name standing for the hull in a sensor's name
HULL = "hull"


@dataclass(frozen=True)
class Sensor:
    """One sensor: where (``bag``, or ``"hull"``), what (``quantity``), how often
    (``rate_Hz``), how well (``noise``: standard deviation in the quantity's SI unit), how
    late (``latency_s``) and how reliably (``dropout``: probability a reading is lost)."""

    bag: str
    quantity: str
    rate_Hz: float
    noise: float
    latency_s: float
    dropout: float

    @property
    def name(self) -> str:
        """``<bag>/<quantity>`` or ``hull/<quantity>``."""
        return f"{self.bag}/{self.quantity}"

    @property
    def period_s(self) -> float:
        return 1.0 / self.rate_Hz


def sensor_name(bag: str, quantity: str) -> str:
    """The sensor name of ``quantity`` at ``bag`` (or ``"hull"``)."""
    return f"{bag}/{quantity}"


def split_name(name: str) -> tuple[str, str]:
    """(bag or "hull", quantity) of a sensor name."""
    bag, _, quantity = name.rpartition("/")
    return bag, quantity


def sensors_of(scenario, bag_names, for_log: bool = False) -> list[Sensor]:
    """The sensors of ``scenario`` on a plant with bags ``bag_names``, in the section's order
    of quantities, each quantity's bags in the plant's order (the hull first).

    Parameters
    ----------
    scenario : Scenario
    bag_names : sequence of str
        The plant's bags (:attr:`flexlift.ascent.plant.Plant.names`).
    for_log : bool, optional
        A scenario without a ``sensors:`` section has the section's defaults
        (:data:`flexlift.scenario.sensors.DEFAULT_FOR_LOG`: ``simulate --sensor-log``);
        default False: it has none.

    Raises
    ------
    InputError
        A bag named in ``sensors.<quantity>.at`` that the plant does not have, or ``hull``
        where the quantity has no hull sensor.
    """
    section: Sensors | None = scenario.sensors
    if section is None:
        if not for_log:
            return []
        section = DEFAULT_FOR_LOG
    names, out = list(bag_names), []
    for quantity in QUANTITIES:
        spec = getattr(section, quantity)
        if spec is None:
            continue
        where = names if spec.at == "all" else list(spec.at)
        for bag in where:
            if bag == HULL and quantity not in HULL_QUANTITIES:
                raise InputError(f"sensors.{quantity}.at", bag, "a hull sensor measures "
                                 f"{' or '.join(HULL_QUANTITIES)} only; name bags")
            if bag != HULL and bag not in names:
                raise InputError(f"sensors.{quantity}.at", bag,
                                 f"no such bag; the bags are {', '.join(names[:8])}"
                                 + (" ..." if len(names) > 8 else ""))
        order = ([HULL] if HULL in where else []) + [b for b in names if b in where]
        out += [Sensor(b, quantity, spec.rate_Hz, spec.noise_si(), spec.latency_s, spec.dropout)
                for b in order]
    return out


def known_names(bag_names) -> set[str]:
    """Every sensor name a plant with ``bag_names`` may have (any bag's quantity, the hull's)."""
    out = {sensor_name(HULL, q) for q in HULL_QUANTITIES}
    out |= {sensor_name(b, q) for b in bag_names for q in QUANTITIES}
    return out
