import json

import pytest

from flexlift.cli import main

KEYS = {"control", "breakout_time_s", "arrival_time_s", "max_ascent_velocity_ms", "max_pitch_deg",
        "max_bending_moment_MNm", "gas_used_free_air_m3", "final_height_m", "criteria", "events"}


def test_simulate_json_short(capsys):
    assert main(["simulate", "--control", "coordinated", "--duration", "200", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert KEYS <= set(out)
    assert out["control"] == "coordinated"
    assert set(out["criteria"]) == {"ascent_velocity", "descent_velocity", "pitch", "reached_target",
                                    "no_surface_breach", "no_resettle", "bending_utilisation"}
    assert out["criteria"]["reached_target"] is False  # 200 s is far too short
    assert all(v is None for v in out["arrival_time_s"].values())


def test_simulate_writes_files(tmp_path, capsys):
    sc = tmp_path / "s.yaml"
    sc.write_text("control:\n  target_height_m: 10.0\nseabed:\n  breakout_time_s: 40.0\n"
                  "simulation:\n  hold_time_s: 20.0\n")
    out = tmp_path / "out"
    assert main(["simulate", str(sc), "--duration", "700", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "criteria:" in text
    from flexlift.output.results import netcdf_modes

    assert netcdf_modes(out / "results.nc") == ["decentralized"]
    assert not (out / "data").exists()  # results.nc is the one netCDF
    assert (out / "tables" / "simulate_decentralized_time_histories.csv").is_file()
    for f in ("bags", "hull", "moment"):
        assert (out / "figures" / f"simulate_decentralized_{f}.png").stat().st_size > 1000


def test_run_stage_and_compare(tmp_path):
    from flexlift import load_scenario
    from flexlift.stages.simulate import compare_stage, run_stage

    sc = load_scenario("tanker")
    outs = [run_stage(sc, tmp_path, control=m, duration=100.0) for m in ("decentralized", "coordinated")]
    cmp = compare_stage(outs, tmp_path)
    assert cmp.figures[0].path.is_file()
    assert outs[0].name == "simulate:decentralized" and set(outs[0].criteria) == set(outs[0].summary["criteria"])


@pytest.mark.parametrize("yaml_text, word", [
    ("faults:\n  - {kind: sling_break, bag: bag_42, time_s: 10}\n", "bag_42"),
    ("simulation:\n  time_step_s: -0.1\n", "time_step_s"),
    ("control:\n  target_height_m: 400\n", "target_height_m"),
])
def test_bad_input_one_line_exit_2(tmp_path, capsys, yaml_text, word):
    p = tmp_path / "bad.yaml"
    p.write_text(yaml_text)
    assert main(["simulate", str(p), "--duration", "10"]) == 2
    err = capsys.readouterr().err
    assert word in err and err.count("\n") == 1 and "Traceback" not in err


def test_bad_control_option(capsys):
    try:
        rc = main(["simulate", "--control", "telepathic"])
    except SystemExit as e:
        rc = e.code
    assert rc == 2
    assert "Traceback" not in capsys.readouterr().err


def test_a_run_without_arrivals_says_so_not_none(capsys):
    from flexlift.cli import main

    main(["simulate", "--duration", "100", "--control", "coordinated"])
    out = capsys.readouterr().out
    assert "no bag arrived" in out and "None" not in out
