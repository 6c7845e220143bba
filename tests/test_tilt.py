"""The tilt criterion (issue 25): 2 deg by default (0027/ND 5.3.2 by analogy), the paper's
15 deg for the built-in tanker, none for a pipe (its bending utilisation governs)."""

import signal
from pathlib import Path

import pytest

from flexlift import load_scenario
from flexlift.ascent import simulate
from flexlift.scenario.defaults import POLICY
from flexlift.scenario.schema import parse_scenario
from flexlift.sweep.aggregate import limits_of

TRAWLER = Path(__file__).parent / "data" / "trawler.yaml"


def test_the_schema_default_is_2_deg_and_the_tanker_keeps_15():
    assert parse_scenario({"name": "x"}).limits.pitch_deg == 2.0
    assert load_scenario("tanker").limits.pitch_deg == 15.0
    user = load_scenario(TRAWLER)
    assert user.limits.pitch_deg == 2.0 and user.defaulted["limits.pitch_deg"] == "assumed"
    assert "0027/ND 5.3.2" in POLICY["limits.pitch_deg"][1]
    assert "by analogy" in POLICY["limits.pitch_deg"][1]


def test_a_pipe_has_no_tilt_criterion_unless_it_gives_one():
    line = load_scenario("pipeline")
    assert line.limits.pitch_deg is None and line.defaulted["limits.pitch_deg"] == "derived"
    again = parse_scenario(line.model_dump(mode="json"))  # its scenario.yaml, rerun
    assert again.limits.pitch_deg is None and again.checksum() == line.checksum()
    given = line.with_changes(**{"limits.pitch_deg": 5.0})
    assert given.limits.pitch_deg == 5.0
    assert "max_pitch_deg" not in limits_of(line) and limits_of(given)["max_pitch_deg"] == 5.0


def _alarm(*_):
    raise TimeoutError("the short pipeline run took longer than 600 s")


@pytest.mark.parametrize("pitch", [None, 0.01])
def test_the_pitch_criterion_is_skipped_and_said_when_it_does_not_apply(pitch):
    line = load_scenario("pipeline").with_changes(**{"limits.pitch_deg": pitch})
    signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(600)
    try:
        r = simulate(line, control="decentralized", duration=60.0)
    finally:
        signal.alarm(0)
    if pitch is None:  # not judged, and no warning on every pipe run: the design basis says so
        assert "pitch" not in r.criteria and not any("tilt" in w for w in r.warnings)
        from flexlift.scenario.basis import design_basis

        tilt = next(row for row in design_basis(line) if row["item"] == "tilt limit")
        assert "not" in str(tilt["value"]).lower() or "none" in str(tilt["value"]).lower(), tilt
    else:  # a limit given is judged
        assert "pitch" in r.criteria


def test_an_empty_section_of_a_users_hull_is_an_empty_section_not_a_crash():
    from flexlift.errors import InputError

    with pytest.raises(InputError, match="water_depth_m is missing"):
        parse_scenario({"hull": {"length_m": 60.0}, "lift": None, "seabed": None})
