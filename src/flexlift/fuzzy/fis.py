"""Import and export of MATLAB ``.fis`` files (Fuzzy Logic Toolbox text format).

A ``.fis`` file has the sections ``[System]``, ``[Input1]``.. ``[InputN]``, ``[Output1]``..
``[OutputM]`` and ``[Rules]``; membership functions are written ``MF1='name':'type',[p1 p2 ...]``
and rules ``i1 .. iN, o1 .. oM (weight) : connective`` with 1-based set indices, 0 = "don't
care" (in an antecedent) or "not in this rule" (in a consequent), a negative index = NOT,
connective 1 = AND, 2 = OR.

Import (:func:`read_fis`, :func:`from_fis_text`) reads what MATLAB's ``readfis`` reads:
Mamdani and Sugeno systems, any number of inputs and outputs, every membership function type
of the Fuzzy Logic Toolbox, comments, both the old and the current header; the details are
in :mod:`flexlift.fuzzy.fis_parse`. What flexlift cannot evaluate (a custom operator or membership
function, a hedge, another system type) and every malformed line raise InputError with one
line naming the file, the line and what is allowed. The output grid size is not part of the
format (MATLAB sets it at evaluation): pass ``resolution`` (default 101, as MATLAB); nor is
the handling of inputs beyond their ranges: ``out_of_range`` (see :mod:`flexlift.fuzzy`).

Export (:func:`to_fis_text`, :func:`write_fis`) writes the current format (``Version=2.0``)
with Python's shortest round-trip repr of every number, so write -> read gives back an equal
FIS, bit for bit. :func:`load_controller_fis` reads a file for one of flexlift's controllers.
"""

from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path

from flexlift.errors import InputError, clean
from flexlift.fuzzy.fis_parse import METHODS, parse_fis
from flexlift.fuzzy.system import FIS, MF
from flexlift.plumbing import reading
from flexlift.plumbing.atomic import write_text

ROLES = ("supervisor", "fill")


def _num(v: float) -> str:
    text = repr(float(v))
    return text[:-2] if text.endswith(".0") else text


def _index(i, negated) -> str:
    return "0" if i is None else str((-1 if negated else 1) * (i + 1))


def to_fis_text(fis: FIS) -> str:
    """The MATLAB ``.fis`` text of ``fis`` (Mamdani or Sugeno, any number of outputs)."""
    lines = ["[System]", f"Name='{fis.name}'", f"Type='{fis.kind}'", "Version=2.0",
             f"NumInputs={fis.n_inputs}", f"NumOutputs={fis.n_outputs}",
             f"NumRules={len(fis.rules)}"]
    lines += [f"{key}='{getattr(fis, attr)}'" for key, (attr, _) in METHODS.items()]
    for title, var in [*((f"Input{i}", v) for i, v in enumerate(fis.inputs, 1)),
                       *((f"Output{i}", v) for i, v in enumerate(fis.outputs, 1))]:
        lines += ["", f"[{title}]", f"Name='{var.name}'",
                  f"Range=[{_num(var.range[0])} {_num(var.range[1])}]", f"NumMFs={len(var.mfs)}"]
        lines += [f"MF{k}='{m.name}':'{m.kind}',[{' '.join(_num(p) for p in m.params)}]"
                  for k, m in enumerate(var.mfs, 1)]
    lines += ["", "[Rules]"]
    for r in fis.rules:
        ante = " ".join(_index(i, n) for i, n in zip(r.antecedent, r.negated))
        cons = " ".join(_index(i, n) for i, n in zip(r.consequents, r.consequents_negated))
        lines.append(f"{ante}, {cons} ({_num(r.weight)}) : {1 if r.connective == 'and' else 2}")
    return "\n".join(lines) + "\n"


def write_fis(fis: FIS, path: str | os.PathLike) -> Path:
    """Write ``fis`` as a MATLAB ``.fis`` file (atomically); returns the path."""
    return write_text(path, to_fis_text(fis))


def read_fis(path: str | os.PathLike, resolution: int = 101, out_of_range: str = "clip") -> FIS:
    """Read a MATLAB ``.fis`` file into a :class:`FIS`: a regular UTF-8 file of at most 1 MB
    (:mod:`flexlift.plumbing.reading`), else one InputError line naming it."""
    text = reading.read_text(path, clean(os.fspath(path), 120), reading.FIS)
    path = Path(path)
    return from_fis_text(text, resolution=resolution, source=path.name, out_of_range=out_of_range)


def from_fis_text(text: str, resolution: int = 101, source: str = ".fis",
                  out_of_range: str = "clip") -> FIS:
    """Parse MATLAB ``.fis`` text; ``source`` names it in error messages."""
    return parse_fis(text, source=source, resolution=resolution, out_of_range=out_of_range)


def load_controller_fis(path: str | os.PathLike, role: str, resolution: int = 101) -> FIS:
    """A user's ``.fis`` file for one of flexlift's fuzzy controllers (docs/theory/control.md#supervisor).

    role "supervisor": two inputs, the normalised height error ``e`` and its rate ``edot``
    (matched by name when the file names them so, else taken in order: first e, then edot),
    and one output ``u`` whose range lies within [-1, 1] (the fraction of ΔV_max).
    role "fill": one input (the normalised signed distance d) and one output (the fill
    command). Mamdani or Sugeno. A file that does not fit the role raises InputError.
    """
    if role not in ROLES:
        raise InputError("role", role, f"allowed: {', '.join(ROLES)}")
    fis = read_fis(path, resolution=resolution)
    source = Path(path).name
    want = (2, "two inputs (e, edot)") if role == "supervisor" else (1, "one input (d)")
    if fis.n_inputs != want[0] or fis.n_outputs != 1:
        raise InputError(source, f"{fis.n_inputs} inputs and {fis.n_outputs} outputs",
                         f"a {role} .fis has {want[1]} and one output")
    if role == "supervisor":
        names = [v.name for v in fis.inputs]
        if set(names) == {"e", "edot"} and names[0] != "e":
            fis = _swapped_inputs(fis)
        lo, hi = fis.output.range
        if lo < -1.0 or hi > 1.0:
            raise InputError(f"{source} output {fis.output.name!r} range", [lo, hi],
                             "a supervisor's output u lies within [-1, 1] (a fraction of ΔV_max)")
    return fis


def _swapped_inputs(fis: FIS) -> FIS:
    """The same two-input system with its inputs in the other order."""
    rules = tuple(replace(r, antecedent=r.antecedent[::-1], negated=r.negated[::-1])
                  for r in fis.rules)
    outputs = tuple(replace(v, mfs=tuple(
        MF(m.name, m.kind, (m.params[1], m.params[0], m.params[2])) if m.kind == "linear" else m
        for m in v.mfs)) for v in fis.outputs)
    return replace(fis, inputs=fis.inputs[::-1], outputs=outputs, rules=rules)


def to_skfuzzy(fis: FIS, input_universe=None):
    """The same system as a scikit-fuzzy ``ControlSystemSimulation``, for cross-checks.

    Supported: Gaussian sets, AND rules of weight 1 with every input named, min/max, centroid
    (scikit-fuzzy's own operators). ``input_universe``: sample points shared by the inputs
    (default 201 points over the first input's range); include the points you will evaluate
    so that scikit-fuzzy's interpolated input memberships are exact there. Returns
    ``(simulation, consequent)``. scikit-fuzzy is a test-only dependency, imported here.
    """
    import numpy as np
    import skfuzzy
    from skfuzzy import control as ctrl

    if any(m.kind != "gaussmf" for v in (*fis.inputs, fis.output) for m in v.mfs):
        raise InputError("fis", fis.name, "to_skfuzzy supports Gaussian sets only")
    if any(r.connective != "and" or r.weight != 1 or any(r.negated) or None in r.antecedent
           for r in fis.rules):
        raise InputError("fis", fis.name, "to_skfuzzy supports plain AND rules of weight 1")
    lo, hi = fis.inputs[0].range
    uni = np.linspace(lo, hi, 201) if input_universe is None else np.asarray(input_universe)
    ants = []
    for var in fis.inputs:
        a = ctrl.Antecedent(uni, var.name)
        for m in var.mfs:
            a[m.name] = skfuzzy.gaussmf(uni, m.params[1], m.params[0])
        ants.append(a)
    out = ctrl.Consequent(fis.output_grid, fis.output.name, defuzzify_method="centroid")
    for m in fis.output.mfs:
        out[m.name] = skfuzzy.gaussmf(out.universe, m.params[1], m.params[0])
    rules = []
    for r in fis.rules:
        terms = [ants[i][fis.inputs[i].mfs[k].name] for i, k in enumerate(r.antecedent)]
        condition = terms[0]
        for term in terms[1:]:
            condition = condition & term
        rules.append(ctrl.Rule(condition, out[fis.output.mfs[r.consequent].name]))
    return ctrl.ControlSystemSimulation(ctrl.ControlSystem(rules)), out
