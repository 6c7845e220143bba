"""Reading MATLAB ``.fis`` text as MATLAB's ``readfis`` does (see :mod:`flexlift.fuzzy.fis`).

Accepted, as MATLAB's reader accepts them: comment lines starting with ``%`` or ``#`` and
blank lines anywhere, a trailing ``%``/``#`` comment after a value, indentation and spaces
around ``=``, ``:`` and ``,``; the current header (``Version=2.0``) and the older one without a
Version line (any Version value is accepted and ignored); ``Type='mamdani'`` or ``'sugeno'``;
any number of inputs (an input may have ``NumMFs=0``) and outputs; rule weights, NOT
(negative indices), OR (connective 2), don't care (0) and whole-number indices written as
decimals (``1.000``). Older files pad every parameter list to four numbers with zeros
(``'trimf',[-10 0 10 0]``, ``'smf',[1 2 0 0]``): zeros beyond a type's count, up to four, are
dropped. MF lines are taken in order (MATLAB's reader ignores the number after ``MF``; one
shipped example, slcp1.fis, has two ``MF2`` lines). Everything else is refused with one line
naming the file, the line and what is allowed: custom operators and membership functions (a
MATLAB function of the user's, or another tool's type), hedges (Octave's fractional indices),
other system types, type-2 sets.

Numbers and counts have limits, so that a hostile file is refused with one line rather than
ending in an overflow, a recursion error or a system that evaluates to NaN: every number (a
range end, a parameter, a weight, an index) is finite and within ±:data:`MAX_MAGNITUDE`; an
arithmetic number (``-pi/4``) has at most :data:`MAX_EXPRESSION` characters; the counts
``NumInputs``, ``NumOutputs`` (1..:data:`MAX_VARIABLES`), ``NumMFs`` (0..:data:`MAX_MFS`)
and ``NumRules`` (0..:data:`MAX_RULES`) are whole numbers; and every membership function is
finite over its variable's range (sampled at 101 points and at each of its parameters inside
the range, where a kernel divides by a width or a sigma).
"""

from __future__ import annotations

import ast
import math
import operator
import re
import warnings

import numpy as np

from flexlift.errors import LINE_LIMIT, InputError, clean
from flexlift.fuzzy.system import (
    AGGREGATIONS,
    ALL_KINDS,
    AND_METHODS,
    DEFUZZIFICATIONS,
    FIS,
    IMPLICATIONS,
    KINDS,
    MF,
    MF_KINDS,
    OR_METHODS,
    SUGENO_DEFUZZIFICATIONS,
    Rule,
    Variable,
)

#: .fis key -> (FIS field, allowed values by system type)
METHODS = {
    "AndMethod": ("and_method", {"mamdani": AND_METHODS, "sugeno": AND_METHODS}),
    "OrMethod": ("or_method", {"mamdani": OR_METHODS, "sugeno": OR_METHODS}),
    "ImpMethod": ("implication", {"mamdani": IMPLICATIONS, "sugeno": IMPLICATIONS}),
    "AggMethod": ("aggregation", {"mamdani": AGGREGATIONS, "sugeno": AGGREGATIONS}),
    "DefuzzMethod": ("defuzzification",
                     {"mamdani": DEFUZZIFICATIONS, "sugeno": SUGENO_DEFUZZIFICATIONS}),
}
#: MATLAB's defaults when a method line is missing (mamfis / sugfis)
DEFAULTS = {"mamdani": ("min", "max", "min", "max", "centroid"),
            "sugeno": ("prod", "probor", "prod", "sum", "wtaver")}
_ROLE = {"AndMethod": "AND method", "OrMethod": "OR method", "ImpMethod": "implication",
         "AggMethod": "aggregation", "DefuzzMethod": "defuzzification"}
SYSTEM_KEYS = ("Name", "Type", "Version", "NumInputs", "NumOutputs", "NumRules", *METHODS)
VARIABLE_KEYS = ("Name", "Range", "NumMFs", "MF1", "MF2", "...")
_SECTION = re.compile(r"^\[(?P<name>[^\]]*)\]$")
_MF_KEY = re.compile(r"^MF\d+$")
_MF_LINE = re.compile(
    r"^'(?P<name>[^']*)'\s*:\s*'(?P<kind>[^']*)'\s*,\s*\[(?P<params>[^\]]*)\]$")
_RULE_LINE = re.compile(
    r"^(?P<ante>[-+\d.eE\s]+),(?P<cons>[-+\d.eE\s]+)\((?P<weight>[^)]*)\)\s*:\s*(?P<conn>\S+)$")
_LEGACY_WIDTH = 4  # old writers padded every parameter list to four numbers
#: largest magnitude of any number in a .fis file: sums and products of such numbers over a
#: range stay finite (a linear output a1 x1 + .. + c, a centroid over the output grid)
MAX_MAGNITUDE = 1e100
#: longest arithmetic number [characters] (``-pi/4``; deeper arithmetic is not a .fis number)
MAX_EXPRESSION = 100
#: most inputs, and most outputs, of a system
MAX_VARIABLES = 100
#: most membership functions of one variable
MAX_MFS = 1_000
#: most rules (more than a 1 MB file can hold)
MAX_RULES = 100_000
#: points at which each membership function is checked to be finite over its range
_SAMPLES = 101


def _strip(raw: str) -> str:
    """The line without a trailing % or # comment (outside quotes) and surrounding blanks."""
    quoted = False
    for i, ch in enumerate(raw):
        if ch == "'":
            quoted = not quoted
        elif ch in "%#" and not quoted:
            return raw[:i].strip()
    return raw.strip()


class _Reader:
    def __init__(self, text: str, source: str):
        self.source = source
        self.sections: dict[str, list[tuple[int, str]]] = {}
        current = None
        for n, raw in enumerate(text.splitlines(), 1):
            line = _strip(raw)
            if not line:
                continue
            m = _SECTION.match(line)
            if m:
                current = m["name"].strip()
                if current in self.sections:
                    self.fail(n, line, "each section appears once")
                self.sections[current] = []
            elif current is None:
                self.fail(n, line, "content must follow a [Section] header: a MATLAB .fis file "
                                   "starts with [System] (comment lines may precede it)")
            else:
                self.sections[current].append((n, line))

    def fail(self, n, line, allowed):
        raise InputError(f"{self.source} line {n}", clean(line, 120), allowed)

    def keys(self, name: str, allowed: tuple[str, ...], needs: str):
        """Key=value lines of a section as {key: (line number, value)}, and its MF lines."""
        if name not in self.sections:
            raise InputError(self.source, f"no [{name}] section", needs)
        out, mfs = {}, []
        for n, line in self.sections[name]:
            key, eq, value = (t.strip() for t in line.partition("="))
            if not eq:
                self.fail(n, line, f"Key=value lines in [{name}]")
            if _MF_KEY.match(key) and "MF1" in allowed:
                mfs.append((n, key, value))
                continue
            if key not in allowed:
                self.fail(n, line, f"[{name}] keys: {', '.join(allowed)}")
            if key in out:
                self.fail(n, line, f"{key} appears once in [{name}]")
            out[key] = (n, value)
        return out, mfs

    def string(self, d, key, where, default=None):
        if key not in d:
            if default is not None:
                return default
            raise InputError(self.source, f"[{where}] without {key}", f"[{where}] needs {key}=...")
        v = d[key][1]
        return v[1:-1] if len(v) >= 2 and v[0] == v[-1] and v[0] in "'\"" else v

    def count(self, d, key, where, most):
        v = self.string(d, key, where)
        try:
            x = float(v)
        except ValueError:
            x = -1.0
        if not math.isfinite(x) or x != int(x) or not 0 <= x <= most:
            self.fail(d[key][0], f"{key}={v}", f"{key} must be a whole number 0..{most:,}")
        return int(x)

    def numbers(self, text, n, line):
        try:
            return tuple(_number(t) for t in text.replace(",", " ").split())
        except _NotANumber as exc:
            self.fail(n, line, f"{exc}; numbers are separated by spaces, finite and within "
                               f"±{MAX_MAGNITUDE:g} (pi and + - * / ^ allowed)")


class _NotANumber(ValueError):
    """A token that is not a number a .fis file may hold; the message says why."""


_BINARY = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul,
           ast.Div: operator.truediv, ast.BitXor: operator.pow}


def _number(token: str) -> float:
    """A number as MATLAB's reader evaluates it: a literal, or arithmetic on literals and pi
    (the shipped sltbu.fis writes Range=[-pi/4 pi/4]); finite and within ±MAX_MAGNITUDE."""
    shown = clean(token, 40)
    try:
        result = float(token)
    except ValueError:
        result = _arithmetic(token)
    if not math.isfinite(result):
        raise _NotANumber(f"{shown} is not finite")
    if abs(result) > MAX_MAGNITUDE:
        raise _NotANumber(f"{shown} is beyond ±{MAX_MAGNITUDE:g}")
    return result


def _arithmetic(token: str) -> float:
    """The value of arithmetic on literals and pi (at most MAX_EXPRESSION characters)."""
    shown = clean(token, 40)
    if len(token) > MAX_EXPRESSION:
        raise _NotANumber(f"{shown} is arithmetic of {len(token):,} characters (at most "
                          f"{MAX_EXPRESSION})")

    def value(node):
        if isinstance(node, ast.Constant) and type(node.value) in (int, float):
            return float(node.value)
        if isinstance(node, ast.Name) and node.id == "pi":
            return math.pi
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub | ast.UAdd):
            v = value(node.operand)
            return -v if isinstance(node.op, ast.USub) else v
        if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
            return _BINARY[type(node.op)](value(node.left), value(node.right))
        raise ValueError(token)

    try:
        with warnings.catch_warnings():  # Python's SyntaxWarning ("invalid decimal literal")
            warnings.simplefilter("ignore")  # would be a second line on stderr
            tree = ast.parse(token, mode="eval")
        result = value(tree.body)
    except OverflowError:
        raise _NotANumber(f"{shown} overflows") from None
    except (SyntaxError, ValueError, ZeroDivisionError, RecursionError, MemoryError, TypeError):
        raise _NotANumber(f"{shown} is not a number") from None
    if not isinstance(result, float):  # a negative number to a fractional power: complex
        raise _NotANumber(f"{shown} is not a real number")
    return result


def parse_fis(text: str, source: str = ".fis", resolution: int = 101,
              out_of_range: str = "clip") -> FIS:
    """A :class:`FIS` from MATLAB ``.fis`` text; ``source`` names it in error messages, which
    are one line of at most :data:`~flexlift.errors.LINE_LIMIT` characters (a name or a value
    of a hostile file's thousands of characters is shortened in the middle)."""
    try:
        return _parse(text, source, resolution, out_of_range)
    except InputError as exc:
        if len(str(exc)) <= LINE_LIMIT:
            raise
        raise InputError.from_line(clean(str(exc), LINE_LIMIT)) from None


def _parse(text: str, source: str, resolution: int, out_of_range: str) -> FIS:
    rd = _Reader(text, source)
    system, _ = rd.keys("System", SYSTEM_KEYS,
                        "a .fis file needs [System], [Input1..N], [Output1..M], [Rules]")
    kind = rd.string(system, "Type", "System").lower()
    if kind not in KINDS:
        rd.fail(system["Type"][0], f"Type='{kind}'", "Type='mamdani' or Type='sugeno'")
    n_in = rd.count(system, "NumInputs", "System", MAX_VARIABLES)
    n_out = rd.count(system, "NumOutputs", "System", MAX_VARIABLES)
    if n_in < 1 or n_out < 1:
        which = "NumInputs" if n_in < 1 else "NumOutputs"
        rd.fail(system[which][0], f"{which}={n_in if n_in < 1 else n_out}", f"{which} >= 1")
    options = {}
    for (key, (attr, allowed)), default in zip(METHODS.items(), DEFAULTS[kind]):
        value = rd.string(system, key, "System", default=default)
        if value not in allowed[kind]:
            other = [k for k, v in allowed.items() if value in v]
            what = (f"is for Type='{other[0]}' systems" if other else
                    f"is a custom {_ROLE[key]} flexlift cannot know")
            rd.fail(system[key][0], f"{key}='{value}'", f"'{clean(value, 40)}' {what}; allowed "
                    f"for Type='{kind}': {', '.join(allowed[kind])}")
        options[attr] = value
    inputs = tuple(_variable(rd, f"Input{i}", kind, n_in, True) for i in range(1, n_in + 1))
    outputs = tuple(_variable(rd, f"Output{i}", kind, n_in, False)
                    for i in range(1, n_out + 1))
    rules = _rules(rd, inputs, outputs, kind)
    declared = rd.count(system, "NumRules", "System", MAX_RULES) if "NumRules" in system else None
    if declared is not None and declared != len(rules):
        rd.fail(system["NumRules"][0], f"NumRules={declared}",
                f"the [Rules] section has {len(rules)} rules")
    if len(rules) > MAX_RULES:
        raise InputError(source, f"{len(rules):,} rules", f"at most {MAX_RULES:,}")
    name = rd.string(system, "Name", "System", default=source.rsplit(".", 1)[0])
    try:
        fis = FIS(name, inputs, outputs, rules, resolution=resolution, kind=kind,
                  out_of_range=out_of_range, **options)
    except InputError as exc:
        raise InputError(source, "system", str(exc)) from None
    _check_finite(fis, source)
    return fis


def _check_finite(fis: FIS, source: str) -> None:
    """Refuse a system with a membership function that is not finite somewhere on its
    variable's range: sampled at :data:`_SAMPLES` points, at each of its parameters inside the
    range (where a kernel divides by a width or a sigma) and, for a Mamdani output, on the
    output grid the inference uses. (A Sugeno output function is finite there by the limit
    on its coefficients.)"""
    titled = [(f"Input{i}", v, ()) for i, v in enumerate(fis.inputs, 1)]
    if fis.kind == "mamdani":
        titled += [(f"Output{i}", v, g) for i, (v, g) in
                   enumerate(zip(fis.outputs, fis.output_grids), 1)]
    with np.errstate(all="ignore"):
        for title, var, grid in titled:
            lo, hi = var.range
            for m in var.mfs:
                inside = [p for p in m.params if lo <= p <= hi]
                x = np.concatenate([np.linspace(lo, hi, _SAMPLES), inside, grid])
                mu = np.asarray(m(x), dtype=float)
                bad = ~np.isfinite(mu)
                if bad.any():
                    raise InputError(f"{source} [{title}] {var.name!r} set {m.name!r}",
                                     f"{m.kind} {list(m.params)}", f"a set finite over the range "
                                     f"[{lo:g}, {hi:g}]; it is {mu[bad][0]} at {x[bad][0]:g}")


def _variable(rd: _Reader, title: str, kind: str, n_in: int, is_input: bool) -> Variable:
    d, lines = rd.keys(title, VARIABLE_KEYS, f"the system declares this {title[:-1].lower()}")
    name = rd.string(d, "Name", title)
    n_r, rng = d.get("Range", (None, None))
    if rng is None:
        raise InputError(rd.source, f"[{title}] without Range", f"[{title}] needs Range=[lo hi]")
    lo_hi = rd.numbers(rng.strip("[]"), n_r, f"Range={rng}")
    if len(lo_hi) != 2:
        rd.fail(n_r, f"Range={rng}", f"[{title}] needs Range=[lo hi]")
    count = rd.count(d, "NumMFs", title, MAX_MFS)
    if len(lines) != count:
        where = lines[count][0] if len(lines) > count else d["NumMFs"][0]
        rd.fail(where, f"NumMFs={count}", f"[{title}] has {len(lines)} MF lines")
    mfs = []
    for n, key, spec in lines:
        mfs.append(_mf(rd, n, f"{key}={spec}", spec, kind, n_in, is_input))
    try:
        return Variable(name, lo_hi, tuple(mfs))
    except InputError as exc:
        rd.fail(n_r, f"Range={rng}", f"{exc.allowed} (the range of {title} {name!r})")


def _mf(rd: _Reader, n: int, line: str, spec: str, kind: str, n_in: int, is_input: bool) -> MF:
    m = _MF_LINE.match(spec)
    if not m:
        rd.fail(n, line, "MFk='name':'type',[p1 p2 ...]")
    mf_kind = m["kind"]
    if mf_kind not in ALL_KINDS:
        rd.fail(n, line, f"membership function type '{clean(mf_kind, 40)}' is a custom function "
                         f"(or another tool's) flexlift cannot know; allowed: {', '.join(ALL_KINDS)}")
    if is_input or kind == "mamdani":
        if mf_kind not in MF_KINDS:
            rd.fail(n, line, f"'{mf_kind}' is a Sugeno output function; input and Mamdani output "
                             f"sets are {', '.join(MF_KINDS)}")
    elif mf_kind not in ("constant", "linear"):
        rd.fail(n, line, "a Sugeno output set is 'constant',[c] or 'linear',[a1 .. an c]")
    params = rd.numbers(m["params"], n, line)
    if mf_kind == "linear":
        if len(params) != n_in + 1:
            rd.fail(n, line, f"linear takes {n_in + 1} parameters for {n_in} inputs: "
                             f"[a1 .. a{n_in} c]")
    else:
        names = MF_KINDS[mf_kind][1] if mf_kind in MF_KINDS else ("c",)
        if len(names) < len(params) <= _LEGACY_WIDTH and not any(params[len(names):]):
            params = params[:len(names)]  # an old writer's zero padding
        if len(params) != len(names):
            rd.fail(n, line, f"{mf_kind} takes {len(names)} parameters [{' '.join(names)}]")
    try:
        return MF(m["name"], mf_kind, params)
    except InputError as exc:
        rd.fail(n, line, exc.allowed)


def _index(rd, n, line, v, var, role):
    if v != int(v):
        rd.fail(n, line, f"set index {v:g} of {role} {var.name!r} is fractional: a hedge "
                         "(Octave's extension), which flexlift does not support")
    if abs(v) > len(var.mfs):
        rd.fail(n, line, f"{role} {var.name!r} has sets 1..{len(var.mfs)} (0 = none), "
                         f"so {int(v)} names a set that does not exist")
    return None if v == 0 else int(abs(v)) - 1


def _rules(rd: _Reader, inputs, outputs, kind) -> tuple[Rule, ...]:
    if "Rules" not in rd.sections:
        raise InputError(rd.source, "no [Rules] section", "a .fis file needs a [Rules] section")
    rules = []
    for n, line in rd.sections["Rules"]:
        m = _RULE_LINE.match(line)
        if not m:
            rd.fail(n, line, "rules are written 'i1 .. iN, o1 .. oM (weight) : 1|2'")
        ante = rd.numbers(m["ante"], n, line)
        cons = rd.numbers(m["cons"], n, line)
        if len(ante) != len(inputs) or len(cons) != len(outputs):
            rd.fail(n, line, f"{len(inputs)} antecedent and {len(outputs)} consequent indices")
        a = tuple(_index(rd, n, line, v, var, "input") for v, var in zip(ante, inputs))
        c = tuple(_index(rd, n, line, v, var, "output") for v, var in zip(cons, outputs))
        if all(i is None for i in a):
            rd.fail(n, line, "a rule needs at least one input set (not all 0)")
        if kind == "sugeno" and any(v < 0 for v in cons):
            rd.fail(n, line, "a Sugeno rule cannot negate its consequent")
        weight = rd.numbers(m["weight"], n, line)
        if len(weight) != 1 or not 0 <= weight[0] <= 1:
            rd.fail(n, line, "a rule weight between 0 and 1 in parentheses")
        if m["conn"] not in ("1", "2"):
            rd.fail(n, line, "connective 1 (AND) or 2 (OR) after the colon")
        rules.append(Rule(a, c, weight=weight[0], connective="and" if m["conn"] == "1" else "or",
                          negated=tuple(v < 0 for v in ante),
                          consequent_negated=tuple(v < 0 for v in cons)))
    return tuple(rules)
