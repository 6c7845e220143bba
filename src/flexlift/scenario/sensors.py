"""The scenario's ``sensors:`` section: which sensors a lift has, their rates, noise, latency
and dropouts (docs/reference/sensor-log.md).

One sub-section per quantity; each says where the quantity is measured (``at``: ``all``, the
bags, or a list of bag names and ``hull``) and how (``rate_Hz``, the noise's standard
deviation in the quantity's SI unit, named with that unit, ``latency_s`` and ``dropout``, the
probability that a reading is lost). A sensor is named ``<bag>/<quantity>`` or
``hull/<quantity>``. A quantity set to ``null`` has no sensors; the section absent means no
sensors at all (``simulate --sensor-log`` then uses the section's defaults: every quantity
at every bag, see :data:`DEFAULT_FOR_LOG`).
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field

from flexlift.scenario.types import MAX_ITEMS, Name, real, whole

#: the quantities a sensor may measure: their SI unit and what they are
QUANTITIES = {
    "depth": ("m", "depth below the surface of the bag's lift point (its pressure gauge)"),
    "pitch": ("rad", "inclinometer: the hull's local slope at the bag's point, bow-up positive "
              "(hull/pitch: the hull's rigid pitch)"),
    "sling_force": ("N", "load cell: the sling's force on the hull"),
    "fill_flow": ("m3/s", "the manifold's meter: the fill flow as free air at the surface"),
    "purge": ("1", "the purge valve's opening feedback, 0 closed .. 1 open"),
    "supply_pressure": ("Pa", "absolute pressure of the gas supply at the bag's fill hose"),
}
#: the quantities a ``hull`` sensor may measure
HULL_QUANTITIES = ("depth", "pitch")


class _Section(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, validate_default=True)


Where = Literal["all"] | Annotated[list[Name], Field(min_length=1, max_length=MAX_ITEMS)]


class _Sensor(_Section):
    at: Where = "all"  # "all": every bag; or bag names, "hull" among them where allowed
    rate_Hz: real(0.001, 1000) = 1.0  # readings per second
    latency_s: real(0, 3600) = 0.0  # a reading arrives (is logged) this long after it is taken
    dropout: real(0, 0.99) = 0.0  # probability a reading is lost

    def noise_si(self) -> float:
        """The noise's standard deviation in the quantity's SI unit."""
        return float(next(v for k, v in self if k.startswith("noise")))


class DepthSensor(_Sensor):
    noise_m: real(0, 100) = 0.05  # a pressure gauge's ~0.01 % of full scale at 350 m


class PitchSensor(_Sensor):
    at: Where = ["hull"]  # the hull's inclinometer; bag names: one at each lift point
    noise_rad: real(0, 1) = 0.002  # ~0.1 degree


class SlingForceSensor(_Sensor):
    noise_N: real(0, 1e8) = 5_000.0  # ~0.1 % of a 500 t load cell's range


class FillFlowSensor(_Sensor):
    noise_m3_s: real(0, 100) = 0.002  # free air


class PurgeSensor(_Sensor):
    noise_fraction: real(0, 1) = 0.01  # of full opening


class SupplyPressureSensor(_Sensor):
    noise_Pa: real(0, 1e7) = 2_000.0


class Sensors(_Section):
    """Which sensors exist (docs/reference/sensor-log.md)."""

    seed: whole(0, 2**63 - 1) = 0  # the readings' noise and dropouts
    depth: DepthSensor | None = DepthSensor()
    pitch: PitchSensor | None = PitchSensor()
    sling_force: SlingForceSensor | None = SlingForceSensor()
    fill_flow: FillFlowSensor | None = FillFlowSensor()
    purge: PurgeSensor | None = PurgeSensor()
    supply_pressure: SupplyPressureSensor | None = SupplyPressureSensor()


#: the sensors ``simulate --sensor-log`` assumes when a scenario has no ``sensors:`` section
DEFAULT_FOR_LOG = Sensors()
