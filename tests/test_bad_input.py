"""Bad input through the CLI: one line on stderr, exit code 2, no traceback, warnings held."""

import pytest

from flexlift.cli import main


def _write(tmp_path, text: str):
    p = tmp_path / "s.yaml"
    p.write_text(text)
    return str(p)


@pytest.mark.parametrize(
    "yaml_text, command, needle",
    [
        ("lift:\n  bag_lift_t: 200\n", "simulate", "must hold its share of the wet weight"),
        ("lift:\n  internal_bags: 7\n", "simulate", "internal bags alone"),
        ("faults:\n  - {kind: sling_break, bag: bag_9, time_s: 1}\n", "simulate", "faults[0].bag"),
        ("simulation:\n  time_step_s: -0.1\n", "simulate", "simulation.time_step_s"),
        ("control:\n  target_height_m: 400\n", "simulate", "control.target_height_m"),
        ("hull:\n  displacement_t: -3\n", "modes", "hull.displacement_t"),
        ("lift:\n  layout: mode_nodes\n  layout_flexible_mode: 40\n", "loads", "layout_flexible_mode"),
        ("hull: [1, 2\n", "run", "malformed YAML"),
        ("control:\n  sequence: {groups: [[Z9]]}\n", "simulate",
         ("control.sequence.groups[0][0]: got 'Z9'", "its bags are bag_1")),
        ("simulation:\n  retained_flexible_modes: many\n", "loads",
         ("simulation.retained_flexible_modes", "or auto")),
    ],
)
def test_one_line_exit_2(tmp_path, capsys, yaml_text, command, needle):
    """``needle``: a text the line holds, or a tuple of them."""
    path = _write(tmp_path, yaml_text)
    args = [command, path] + (["--out", str(tmp_path / "o"), "--quiet"] if command == "run" else [])
    assert main(args) == 2
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    needles = (needle,) if isinstance(needle, str) else needle
    assert all(n in lines[0] for n in needles) and "Traceback" not in err
    assert not (tmp_path / "o").exists()


def test_shortfall_is_a_warning_printed_after_success(tmp_path, capsys):
    path = _write(tmp_path, "lift:\n  bag_lift_t: 450\n")
    assert main(["loads", path, "--json"]) == 0
    cap = capsys.readouterr()
    assert cap.out.startswith("{")
    assert "467 t short" in cap.err and "WARNING" in cap.err
