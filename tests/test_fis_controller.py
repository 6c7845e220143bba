"""load_controller_fis: a user's .fis file for the supervisor or the fill map, or one clear line."""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from flexlift.errors import InputError
from flexlift.fuzzy.fis import load_controller_fis, write_fis
from flexlift.fuzzy.rulebase import fill_fis, supervisor_fis
from flexlift.fuzzy.system import FIS, MF, Rule, Variable

CORPUS = Path(__file__).parent / "data" / "fis"
Q = np.random.default_rng(3).uniform(-1, 1, (200, 2))


def test_the_built_in_systems_load_for_their_roles(tmp_path):
    sup = supervisor_fis(implication="prod")
    assert load_controller_fis(write_fis(sup, tmp_path / "s.fis"), "supervisor") == sup
    fill = fill_fis().fis
    assert load_controller_fis(write_fis(fill, tmp_path / "f.fis"), "fill") == fill


def test_supervisor_inputs_are_matched_by_name(tmp_path):
    sup = supervisor_fis()
    e, edot = sup.inputs
    asymmetric = tuple(Rule((i, min(j, 2)), min(i + 1, 6)) for i in range(7) for j in range(7))
    ordered = replace(sup, rules=asymmetric)
    swapped = replace(ordered, inputs=(edot, e),
                      rules=tuple(replace(r, antecedent=r.antecedent[::-1]) for r in asymmetric))
    np.testing.assert_array_equal(swapped(Q[:, ::-1]), ordered(Q))  # the same system
    loaded = load_controller_fis(write_fis(swapped, tmp_path / "sw.fis"), "supervisor")
    assert [v.name for v in loaded.inputs] == ["e", "edot"]
    np.testing.assert_array_equal(loaded(Q), ordered(Q))
    # other names: taken in order, first e then edot
    renamed = replace(swapped, inputs=(replace(edot, name="a"), replace(e, name="b")))
    by_order = load_controller_fis(write_fis(renamed, tmp_path / "ab.fis"), "supervisor")
    np.testing.assert_array_equal(by_order(Q), swapped(Q))


def test_a_sugeno_supervisor_keeps_its_linear_coefficients_with_its_inputs(tmp_path):
    x = Variable("edot", (-1, 1), (MF("n", "zmf", (-1, 1)), MF("p", "smf", (-1, 1))))
    y = Variable("e", (-1, 1), ())
    u = Variable("u", (-1, 1), (MF("l", "linear", (0.2, 0.7, -0.1)), MF("c", "constant", (0.3,))))
    fis = FIS("sg", (x, y), u, (Rule((0, None), 0), Rule((1, None), 1)), kind="sugeno",
              defuzzification="wtaver")
    loaded = load_controller_fis(write_fis(fis, tmp_path / "sg.fis"), "supervisor")
    assert loaded.output.mfs[0].params == (0.7, 0.2, -0.1)
    np.testing.assert_allclose(loaded(Q), fis(Q[:, ::-1]), rtol=1e-15)


@pytest.mark.parametrize(
    "name, role, match",
    [("matlab/tipper.fis", "supervisor", r"tip' range: got \[0.0, 30.0\]; .*within \[-1, 1\]"),
     ("matlab/mam22.fis", "supervisor", "2 inputs and 2 outputs.*two inputs .e, edot. and one"),
     ("matlab/slbb.fis", "supervisor", "4 inputs and 1 outputs"),
     ("matlab/tipper.fis", "fill", "a fill .fis has one input .d. and one output"),
     ("matlab/juggler.fis", "fill", "juggler.fis line 32"),
     ("matlab/tipper1.fis", "pitch", "role: got 'pitch'; allowed: supervisor, fill")],
)
def test_files_that_do_not_fit_the_role(name, role, match):
    with pytest.raises(InputError, match=match) as exc:
        load_controller_fis(CORPUS / name, role)
    assert "\n" not in str(exc.value)


def test_a_real_one_input_file_fits_the_fill_role():
    fis = load_controller_fis(CORPUS / "matlab" / "tipper1.fis", "fill")
    assert fis.n_inputs == 1 and fis.output.name == "tip"
