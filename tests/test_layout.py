"""The package's layout keeps data and imports flowing one way (docs/development/design.md#layers): no import cycles,
and each layer imports only from the layers before it."""

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "flexlift"

#: each subpackage may import only from these (and the top-level helpers)
ALLOWED = {
    "plumbing": set(),  # atomic writes, bounded reads, the output lock: the bottom floor
    "scenario": {"physics"},  # a pipe's section laws fill its hull (scenario/pipe.py)
    "structure": {"scenario", "physics"},
    "loads": {"scenario", "structure", "physics"},
    "dynamics": {"scenario", "structure"},
    "fuzzy": {"scenario"},
    "physics": set(),  # the laws: first, used by the lift plan, the loop and the strength
    "control": {"scenario", "fuzzy", "physics"},
    "ascent": {"scenario", "structure", "loads", "dynamics", "fuzzy", "physics", "control"},
    # what a lift's sensors give, read off the loop's state (sensors/truth.py), and its log
    "sensors": {"scenario", "physics", "ascent"},
    # the filter over the plant (estimate/): the loop's ensemble, the sensors' readings
    "estimate": {"scenario", "structure", "loads", "dynamics", "fuzzy", "physics", "control",
                 "ascent", "sensors"},
    # (a replay's folder: output/replay.py reads the estimate's record of what it gives)
    "output": {"scenario", "structure", "loads", "dynamics", "fuzzy", "physics", "control",
               "ascent", "sensors", "estimate"},
    # rig and live; live --estimate runs the estimator (estimate/, a layer below)
    "live": {"scenario", "physics", "control", "ascent", "sensors", "estimate", "output"},
    "stages": {"scenario", "structure", "loads", "dynamics", "fuzzy", "physics", "control",
               "ascent", "output", "sensors"},
    "sweep": {"scenario", "structure", "loads", "dynamics", "fuzzy", "physics", "control",
              "ascent", "output", "stages"},
    # the plan search: the static checks, the batch loop, the single failures and the study
    "design": {"scenario", "structure", "loads", "physics", "ascent", "output", "stages",
               "sweep"},
    "cli": {"scenario", "structure", "loads", "dynamics", "fuzzy", "physics", "control",
            "ascent", "sensors", "estimate", "output", "stages", "sweep", "live", "design"},
}
TOP = {"constants", "errors", "_jit", "_struct", "_threads", "_worker_process", "__init__",
       "__main__"}
#: the bottom floor every layer may use (flexlift.plumbing: files written and read, the lock)
BOTTOM = {"plumbing"}


def _module(path: Path) -> str:
    rel = path.relative_to(SRC.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _imports(path: Path) -> set[str]:
    """flexlift modules imported at module level or inside functions (any import counts)."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("flexlift"):
            out.add(node.module)
            for a in node.names:
                out.add(f"{node.module}.{a.name}")
        elif isinstance(node, ast.Import):
            out |= {a.name for a in node.names if a.name.startswith("flexlift")}
    return out


def _graph():
    mods = {_module(p): p for p in SRC.rglob("*.py")}
    return mods, {m: {i for i in _imports(p) if i in mods and i != m} for m, p in mods.items()}


def test_no_two_modules_import_each_other_even_inside_functions():
    """A lazy import inside a function hides a circle from the module-level check above (as
    scenario/basis.py <-> scenario/valves.py did): no two modules import each other at any
    level, but for a package and its own modules (``from flexlift.scenario import catalogue``
    names the package)."""
    _, graph = _graph()
    pairs = sorted({tuple(sorted((a, b))) for a in graph for b in graph[a]
                    if a in graph.get(b, ()) and not (a.startswith(b + ".")
                                                      or b.startswith(a + "."))})
    assert pairs == []


def test_no_import_cycles_at_module_level():
    mods, _ = _graph()
    top_level = {}
    for m, p in mods.items():
        tree = ast.parse(p.read_text())
        deps = set()
        for node in tree.body:  # module-level imports only: a cycle there breaks import
            if isinstance(node, ast.ImportFrom) and node.module and node.module in mods:
                subs = {f"{node.module}.{a.name}" for a in node.names} & set(mods)
                deps |= subs or {node.module}  # `from pkg import module` needs the module
            elif isinstance(node, ast.Import):
                deps |= {a.name for a in node.names if a.name in mods}
        top_level[m] = deps - {m}
    seen, stack = set(), []

    def visit(m):
        if m in stack:
            raise AssertionError("import cycle: " + " -> ".join(stack[stack.index(m):] + [m]))
        if m in seen:
            return
        stack.append(m)
        for d in sorted(top_level[m]):
            visit(d)
        stack.pop()
        seen.add(m)

    for m in sorted(top_level):
        visit(m)


@pytest.mark.parametrize("package", sorted(ALLOWED))
def test_each_layer_imports_only_the_layers_before_it(package):
    mods, graph = _graph()
    bad = []
    for m, deps in graph.items():
        parts = m.split(".")
        if len(parts) < 2 or parts[1] != package:
            continue
        for d in deps:
            layer = d.split(".")[1] if d.count(".") else ""
            if (layer in TOP or layer == package or layer in ALLOWED[package] or not layer
                    or layer in BOTTOM):
                continue
            bad.append(f"{m} imports {d}")
    assert not bad, bad


def test_the_library_does_not_print():
    offenders = []
    for p in SRC.rglob("*.py"):
        if "cli" in p.relative_to(SRC).parts:
            continue
        for node in ast.walk(ast.parse(p.read_text())):
            if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "print":
                offenders.append(str(p.relative_to(SRC)))
    assert not offenders, offenders


def test_the_packages_docstring_lists_the_layers_this_test_enforces():
    """src/flexlift/__init__.py names the floors in order; every layer's allowed imports are
    floors below it in that order, and every layer is named."""
    import re

    import flexlift

    m = re.search(r"layers: (.*?)\n\n", flexlift.__doc__, flags=re.S)
    order = [w.strip() for w in m.group(1).replace("\n", " ").split(",")]
    assert set(order) == set(ALLOWED), (order, sorted(ALLOWED))
    for layer, allowed in ALLOWED.items():
        below = set(order[: order.index(layer)])
        assert allowed <= below, (layer, sorted(allowed - below))
