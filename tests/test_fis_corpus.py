"""Real .fis files as published (tests/data/fis, see SOURCES.md): MATLAB's shipped examples,
the Octave toolkit's, fuzzylite's exports. Each imports and evaluates as its reference says,
or is refused with one line naming the file, the line and the reason."""

import itertools
import re
from pathlib import Path

import numpy as np
import pytest
from fis_reference import evaluate

from flexlift.errors import InputError
from flexlift.fuzzy.fis import read_fis, write_fis

CORPUS = Path(__file__).parent / "data" / "fis"

#: file -> (type, inputs, outputs, rules)
IMPORTS = {
    "matlab/tipper.fis": ("mamdani", 2, 1, 3),
    "matlab/tipper1.fis": ("mamdani", 1, 1, 3),
    "matlab/mam21.fis": ("mamdani", 2, 1, 4),
    "matlab/mam22.fis": ("mamdani", 2, 2, 4),
    "matlab/shower.fis": ("mamdani", 2, 2, 9),
    "matlab/tank.fis": ("mamdani", 2, 1, 5),
    "matlab/tank2.fis": ("mamdani", 2, 1, 4),
    "matlab/fpeaks.fis": ("sugeno", 2, 1, 16),
    "matlab/invkine1.fis": ("sugeno", 2, 1, 49),
    "matlab/invkine2.fis": ("sugeno", 2, 1, 36),
    "matlab/membrn1.fis": ("sugeno", 2, 1, 4),
    "matlab/membrn2.fis": ("sugeno", 2, 1, 9),
    "matlab/slbb.fis": ("sugeno", 4, 1, 16),
    "matlab/slcp.fis": ("sugeno", 4, 1, 16),
    "matlab/slcp1.fis": ("sugeno", 5, 1, 3),
    "matlab/slcpp1.fis": ("sugeno", 7, 1, 11),
    "matlab/sltbu.fis": ("sugeno", 3, 1, 2),
    "matlab/sltbu_fl.fis": ("sugeno", 3, 1, 2),
    "matlab/sugeno1.fis": ("sugeno", 1, 1, 2),
    "matlab/tanksg.fis": ("sugeno", 2, 1, 5),
    "matlab/tippersg.fis": ("sugeno", 2, 1, 3),
    "octave/mamdani_tip_calculator.fis": ("mamdani", 2, 2, 4),
    "octave/cubic_approximator.fis": ("sugeno", 1, 1, 11),
    "octave/heart_disease_risk.fis": ("sugeno", 2, 1, 15),
    "octave/linear_tip_calculator.fis": ("sugeno", 2, 1, 4),
    "fuzzylite/mamdani/SimpleDimmer.fis": ("mamdani", 1, 1, 3),
    "fuzzylite/takagi-sugeno/SimpleDimmer.fis": ("sugeno", 1, 1, 3),
    "fuzzylite/mamdani/matlab/mam22.fis": ("mamdani", 2, 2, 4),
    "fuzzylite/mamdani/matlab/shower.fis": ("mamdani", 2, 2, 9),
    "fuzzylite/takagi-sugeno/matlab/invkine1.fis": ("sugeno", 2, 1, 49),
    "fuzzylite/takagi-sugeno/matlab/slcpp1.fis": ("sugeno", 7, 1, 11),
}
#: file -> (line, reason): what flexlift lacks or what is wrong in the file
REFUSED = {
    "matlab/juggler.fis": (32, "Range=.0 0.*lo < hi"),
    "octave/investment_portfolio.fis": (32, "'einstein_product' is a custom AND method"),
    "octave/sugeno_tip_calculator.fis": (38, "'einstein_product' is a custom AND method"),
    "fuzzylite/mamdani/AllTerms.fis": (22, "'rampmf' is a custom function"),
    "fuzzylite/mamdani/Laundry.fis": (20, "'discretemf' is a custom function"),
    "fuzzylite/hybrid/tipper.fis": (5, "Type='mamdani' or Type='sugeno'"),
    "fuzzylite/takagi-sugeno/approximation.fis": (48, "'function' is a custom function"),
}


def test_the_corpus_is_what_sources_md_lists():
    files = {p.relative_to(CORPUS).as_posix() for p in CORPUS.rglob("*.fis")}
    assert files == set(IMPORTS) | set(REFUSED)
    assert len(IMPORTS) >= 20
    listed = set(re.findall(r"^\| (\S+\.fis) \|", (CORPUS / "SOURCES.md").read_text(), re.M))
    assert listed == files


def _text_counts(path: Path):
    """Sets and rules counted from the text itself, plainly (comment and blank lines skipped)."""
    lines = [ln.strip() for ln in path.read_text().splitlines()]
    lines = [ln for ln in lines if ln and ln[0] not in "%#"]
    sets = sum(1 for ln in lines if re.match(r"MF\d+\s*=", ln))
    rules = lines[lines.index("[Rules]") + 1:]
    names = [re.match(r"Name\s*=\s*'([^']*)'", ln)[1] for ln in lines if ln.startswith("Name")]
    return sets, len(rules), names


def _grid(fis, n=11):
    lo = np.array([v.range[0] for v in fis.inputs])
    hi = np.array([v.range[1] for v in fis.inputs])
    if fis.n_inputs <= 2:
        axes = [np.linspace(a, b, n) for a, b in zip(lo, hi)]
    else:
        axes = [np.array([a, 0.5 * (a + b), b]) for a, b in zip(lo, hi)]
    pts = np.array(list(itertools.product(*axes)))
    if fis.n_inputs > 2:
        pts = np.concatenate([pts, np.random.default_rng(0).uniform(lo, hi, (100, fis.n_inputs))])
    return pts


@pytest.mark.parametrize("name", sorted(IMPORTS))
def test_file_imports_and_evaluates_as_the_reference(name, tmp_path):
    path = CORPUS / name
    fis = read_fis(path)
    assert (fis.kind, fis.n_inputs, fis.n_outputs, len(fis.rules)) == IMPORTS[name]
    sets, rules, names = _text_counts(path)
    assert sum(len(v.mfs) for v in (*fis.inputs, *fis.outputs)) == sets
    assert len(fis.rules) == rules
    assert [fis.name, *(v.name for v in (*fis.inputs, *fis.outputs))] == names
    pts = _grid(fis)
    ours = np.asarray(fis(pts)).reshape(len(pts), fis.n_outputs)
    ref = np.array([evaluate(fis, p) for p in pts])
    span = np.array([v.range[1] - v.range[0] for v in fis.outputs])
    err = np.abs(ours - ref) / np.maximum(span, np.abs(ref))
    assert err.max() < 1e-12, f"worst relative error {err.max():.2e}"
    back = read_fis(write_fis(fis, tmp_path / "back.fis"))  # export writes what import reads
    assert back == fis
    np.testing.assert_array_equal(np.asarray(back(pts)), np.asarray(fis(pts)))


@pytest.mark.parametrize("name", sorted(REFUSED))
def test_file_is_refused_with_one_line(name):
    line, reason = REFUSED[name]
    with pytest.raises(InputError, match=reason) as exc:
        read_fis(CORPUS / name)
    msg = str(exc.value)
    assert msg.startswith(f"{Path(name).name} line {line}: ") and "\n" not in msg


def test_tipper_as_matlab_documents_it():
    fis = read_fis(CORPUS / "matlab/tipper.fis")  # the old header, a % comment on line 1
    # mathworks.com/help/fuzzy/evalfis.html: [2 1; 4 5; 7 8]; the getting-started example: [1 2]
    np.testing.assert_allclose(fis([[2, 1], [4, 5], [7, 8], [1, 2]]),
                               [7.0169, 14.4585, 20.3414, 5.5586], atol=5e-5)
    assert fis.rules[1].antecedent == (1, None) and fis.rules[0].connective == "or"


def test_the_quirks_of_old_files_read_as_matlab_reads_them():
    shower = read_fis(CORPUS / "matlab/shower.fis")  # trimf written [a b c 0]
    assert shower.inputs[0].mfs[1].params == (-10.0, 0.0, 10.0)
    assert shower.outputs[1].name == "hot" and shower.rules[0].consequent == (3, 4)
    slcp1 = read_fis(CORPUS / "matlab/slcp1.fis")  # 'MF2' twice: MF lines are read in order
    assert slcp1.inputs[4].labels == ("small", "medium", "large")
    assert slcp1.inputs[4].mfs[2].params == (0.2, 1.5)  # gaussmf [0.2 1.5 0 0]
    assert [len(v.mfs) for v in slcp1.inputs] == [0, 0, 0, 0, 3]
    sltbu = read_fis(CORPUS / "matlab/sltbu.fis")  # Range = [-pi/4 pi/4]
    assert sltbu.inputs[1].range == (-np.pi / 4, np.pi / 4)
    edited = read_fis(CORPUS / "matlab/sltbu_fl.fis")  # the same with #Range comment lines
    assert edited.inputs[1].range == (-0.7853982, 0.7853982)
    pts = np.random.default_rng(2).uniform([0, -0.78, -0.78], [25, 0.78, 0.78], (50, 3))
    np.testing.assert_allclose(sltbu(pts), edited(pts), rtol=1e-12)
    # fuzzylite's re-export (3 decimals) of a MATLAB example gives nearly the same numbers
    a, b = read_fis(CORPUS / "matlab/mam22.fis"), read_fis(CORPUS / "fuzzylite/mamdani/matlab/mam22.fis")
    q = _grid(a)
    assert np.abs(a(q) - b(q)).max() < 5e-3
