"""Import and export of MATLAB ``.fis`` files (Fuzzy Logic Toolbox text format, Mamdani).

A ``.fis`` file has the sections ``[System]``, ``[Input1]``.. ``[InputN]``, ``[Output1]`` and
``[Rules]``; membership functions are written ``MF1='name':'type',[p1 p2 ...]`` and rules
``i1 i2 ..., o (weight) : connective`` with 1-based set indices, 0 = "don't care", a negative
index = NOT, connective 1 = AND, 2 = OR.

Supported: Mamdani systems with one output and the membership function types of
:mod:`flexlift.fuzzy` (gaussmf, gauss2mf, trimf, trapmf, gbellmf, sigmf). Anything else
(Sugeno, several outputs, another type, a rule naming a missing set) raises InputError with
one line naming the file, the line and what is allowed. The output grid size is not part of
the format (MATLAB sets it at evaluation): pass ``resolution`` (default 101, as MATLAB).
Numbers are written with Python's shortest round-trip repr, so write -> read is exact.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

from flexlift._io import write_text
from flexlift.errors import InputError
from flexlift.fuzzy import (
    AGGREGATIONS,
    AND_METHODS,
    DEFUZZIFICATIONS,
    FIS,
    IMPLICATIONS,
    MF,
    MF_KINDS,
    OR_METHODS,
    Rule,
    Variable,
)

_METHODS = {
    "AndMethod": ("and_method", AND_METHODS),
    "OrMethod": ("or_method", OR_METHODS),
    "ImpMethod": ("implication", IMPLICATIONS),
    "AggMethod": ("aggregation", AGGREGATIONS),
    "DefuzzMethod": ("defuzzification", DEFUZZIFICATIONS),
}
_MF_LINE = re.compile(r"^'(?P<name>[^']*)'\s*:\s*'(?P<kind>[^']*)'\s*,\s*\[(?P<params>[^\]]*)\]$")
_RULE_LINE = re.compile(
    r"^(?P<ante>[-+\d.\s]+),(?P<cons>[-+\d.\s]+)\((?P<weight>[^)]*)\)\s*:\s*(?P<conn>\d+)$")


def _num(v: float) -> str:
    text = repr(float(v))
    return text[:-2] if text.endswith(".0") else text


def to_fis_text(fis: FIS) -> str:
    """The MATLAB ``.fis`` text of a one-output Mamdani ``fis``."""
    inv = {v[0]: k for k, v in _METHODS.items()}
    lines = ["[System]", f"Name='{fis.name}'", "Type='mamdani'", "Version=2.0",
             f"NumInputs={fis.n_inputs}", "NumOutputs=1", f"NumRules={len(fis.rules)}"]
    lines += [f"{inv[attr]}='{getattr(fis, attr)}'" for attr in inv]
    for title, var in [*((f"Input{i}", v) for i, v in enumerate(fis.inputs, 1)),
                       ("Output1", fis.output)]:
        lines += ["", f"[{title}]", f"Name='{var.name}'",
                  f"Range=[{_num(var.range[0])} {_num(var.range[1])}]", f"NumMFs={len(var.mfs)}"]
        lines += [f"MF{k}='{m.name}':'{m.kind}',[{' '.join(_num(p) for p in m.params)}]"
                  for k, m in enumerate(var.mfs, 1)]
    lines += ["", "[Rules]"]
    for r in fis.rules:
        ante = " ".join("0" if i is None else str((-1 if n else 1) * (i + 1))
                        for i, n in zip(r.antecedent, r.negated))
        cons = (-1 if r.consequent_negated else 1) * (r.consequent + 1)
        lines.append(f"{ante}, {cons} ({_num(r.weight)}) : {1 if r.connective == 'and' else 2}")
    return "\n".join(lines) + "\n"


def write_fis(fis: FIS, path: str | os.PathLike) -> Path:
    """Write ``fis`` as a MATLAB ``.fis`` file (atomically); returns the path."""
    return write_text(path, to_fis_text(fis))


def read_fis(path: str | os.PathLike, resolution: int = 101) -> FIS:
    """Read a MATLAB ``.fis`` file (Mamdani, one output) into a :class:`FIS`."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        raise InputError("--fis", str(path), f"a readable .fis file ({exc.strerror})") from None
    return from_fis_text(text, resolution=resolution, source=path.name)


def from_fis_text(text: str, resolution: int = 101, source: str = ".fis") -> FIS:
    """Parse MATLAB ``.fis`` text; ``source`` names it in error messages."""
    sections: dict[str, list[tuple[int, str]]] = {}
    current = None
    for n, raw in enumerate(text.splitlines(), 1):
        line = raw.strip()
        if not line:
            continue
        if line.startswith("[") and line.endswith("]"):
            current = line[1:-1].strip()
            if current in sections:
                raise InputError(f"{source} line {n}", line, "each section appears once")
            sections[current] = []
        elif current is None:
            raise InputError(f"{source} line {n}", line, "content must follow a [Section] header")
        else:
            sections[current].append((n, line))

    def fail(n, line, allowed):
        raise InputError(f"{source} line {n}", line, allowed)

    def keys(name):
        if name not in sections:
            raise InputError(source, f"no [{name}] section",
                             "a Mamdani .fis needs [System], [Input1..N], [Output1], [Rules]")
        out = {}
        for n, line in sections[name]:
            key, eq, value = line.partition("=")
            if not eq:
                fail(n, line, "Key=value lines in this section")
            out[key.strip()] = (n, value.strip())
        return out

    def string(d, key, where):
        if key not in d:
            raise InputError(source, f"[{where}] without {key}", f"[{where}] needs {key}=...")
        n, v = d[key]
        return v[1:-1] if len(v) >= 2 and v[0] == v[-1] == "'" else v

    def integer(d, key, where):
        v = string(d, key, where)
        try:
            return int(v)
        except ValueError:
            fail(d[key][0], f"{key}={v}", f"{key} must be a whole number")

    system = keys("System")
    kind = string(system, "Type", "System").lower()
    if kind != "mamdani":
        fail(system["Type"][0], f"Type='{kind}'", "only Mamdani systems are supported")
    n_in, n_out = integer(system, "NumInputs", "System"), integer(system, "NumOutputs", "System")
    if n_out != 1:
        fail(system["NumOutputs"][0], f"NumOutputs={n_out}", "only one output is supported")
    options = {}
    for key, (attr, allowed) in _METHODS.items():
        if key in system:
            value = string(system, key, "System")
            if value not in allowed:
                fail(system[key][0], f"{key}='{value}'", f"{key} allowed: {', '.join(allowed)}")
            options[attr] = value

    def variable(title):
        d = keys(title)
        name = string(d, "Name", title)
        n_r, rng = d.get("Range", (0, ""))
        nums = _floats(rng.strip("[]"), n_r, f"Range={rng}", fail)
        if len(nums) != 2:
            fail(n_r, f"Range={rng}", f"[{title}] needs Range=[lo hi]")
        count = integer(d, "NumMFs", title)
        mfs = []
        for k in range(1, count + 1):
            if f"MF{k}" not in d:
                raise InputError(source, f"[{title}] without MF{k}", f"NumMFs={count} sets")
            n, spec = d[f"MF{k}"]
            m = _MF_LINE.match(spec)
            if not m:
                fail(n, f"MF{k}={spec}", "MFk='name':'type',[p1 p2 ...]")
            if m["kind"] not in MF_KINDS:
                fail(n, f"MF{k}={spec}", f"membership types allowed: {', '.join(MF_KINDS)}")
            try:
                mfs.append(MF(m["name"], m["kind"], _floats(m["params"], n, spec, fail)))
            except InputError as exc:
                fail(n, f"MF{k}={spec}", str(exc))
        try:
            return Variable(name, tuple(nums), tuple(mfs))
        except InputError as exc:
            fail(n_r, f"[{title}]", str(exc))

    inputs = tuple(variable(f"Input{i}") for i in range(1, n_in + 1))
    output = variable("Output1")
    rules = []
    for n, line in sections.get("Rules", []):
        m = _RULE_LINE.match(line)
        if not m:
            fail(n, line, "rules are written 'i1 i2 ..., o (weight) : 1|2'")
        ante = _floats(m["ante"], n, line, fail)
        cons = _floats(m["cons"], n, line, fail)
        if len(ante) != n_in or len(cons) != 1 or any(v != int(v) for v in (*ante, *cons)):
            fail(n, line, f"{n_in} whole-number antecedent indices and 1 consequent index")
        for v, var in zip(ante, inputs):
            if abs(v) > len(var.mfs):
                fail(n, line, f"input {var.name!r} has sets 1..{len(var.mfs)} (0 = any)")
        if not 1 <= abs(cons[0]) <= len(output.mfs):
            fail(n, line, f"output {output.name!r} has sets 1..{len(output.mfs)}")
        if m["conn"] not in ("1", "2"):
            fail(n, line, "connective 1 (AND) or 2 (OR)")
        weight = _floats(m["weight"], n, line, fail)
        if len(weight) != 1 or not 0 <= weight[0] <= 1:
            fail(n, line, "a rule weight between 0 and 1 in parentheses")
        rules.append(Rule(tuple(None if v == 0 else int(abs(v)) - 1 for v in ante),
                          int(abs(cons[0])) - 1, weight=weight[0],
                          connective="and" if m["conn"] == "1" else "or",
                          negated=tuple(v < 0 for v in ante), consequent_negated=cons[0] < 0))
    if "NumRules" in system and integer(system, "NumRules", "System") != len(rules):
        fail(system["NumRules"][0], f"NumRules={integer(system, 'NumRules', 'System')}",
             f"the [Rules] section has {len(rules)} rules")
    try:
        return FIS(string(system, "Name", "System"), inputs, output, tuple(rules),
                   resolution=resolution, **options)
    except InputError as exc:
        raise InputError(source, "system", str(exc)) from None


def _floats(text: str, n: int, line: str, fail) -> tuple[float, ...]:
    try:
        return tuple(float(t) for t in text.replace(",", " ").split())
    except ValueError:
        fail(n, line, "numbers separated by spaces")


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
