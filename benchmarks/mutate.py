"""The mutation check: change one physical, control or integration term, and the tests must fail.

``./dev mutate`` (or ``python benchmarks/mutate.py``) runs every mutation of :data:`MUTATIONS`
on a fresh copy of ``src/`` and ``tests/`` in a temporary folder: the copy's ``src`` is put
first on ``PYTHONPATH`` (checked: ``flexlift.__file__`` must be the copy's), numba's cache goes
to the copy's own folder (``NUMBA_CACHE_DIR``: mutants never read or pollute each other's or the
checkout's compiled code; each recompiles the loop, ~40-60 s), and :data:`TESTS` run with
``pytest -x``. A mutant is *killed* when the tests fail, *survived* when they pass, *timeout*
(counted as killed: the suite did not pass) when they hang past the limit, and *error* when
the mutation could not be applied or pytest itself broke (not counted as killed).

Why not mutmut: it mutates every operator it finds (thousands of mutants, most in glue code),
and each mutant of a compiled module costs a full numba compile, so a run would take days on
two cores; a short list of hand-written mutations, each one wrong term of a law, says more
about the suite per minute and reads as a list of the laws it guards.

The unmutated copy runs first (it must pass; its time sets the timeout). Results: a table on
stdout and ``benchmarks/mutation.json`` (each mutation, outcome, seconds, the first failing
test, and the score). Options: ``--only NAME ...``, ``--list``, ``--tests FILE ...`` (another
test subset, e.g. to see what the suite without a file kills), ``--json PATH``, ``--keep``.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import asdict, dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
#: the tests each mutant runs, fastest to fail first (pytest -x stops at the first failure)
TESTS = ("tests/test_physics.py", "tests/test_controller.py", "tests/test_control_laws.py",
         "tests/test_plant_laws.py", "tests/test_supply.py", "tests/test_results.py",
         "tests/test_simulate.py", "tests/test_staged_lift.py", "tests/test_bag_types.py",
         "tests/test_casecost.py", "tests/test_step_control.py")


@dataclass(frozen=True)
class Mutation:
    """One wrong term: in ``file`` (under src/flexlift/), ``original`` (occurring exactly once)
    becomes ``replacement``."""

    name: str
    file: str
    original: str
    replacement: str
    description: str


M = Mutation
MUTATIONS = (
    # ------------------------------------------------------------------ the laws themselves
    M("purge-orifice-law", "physics/gas.py",
      "purge_max * np.sqrt(frac)", "purge_max * frac",
      "purge orifice flow proportional to V/V_max instead of sqrt(V/V_max)"),
    M("gauge-pressure", "physics/gas.py",
      "return p_atm + rho_g * np.maximum(water_depth - height, 0.0)",
      "return rho_g * np.maximum(water_depth - height, 0.0)",
      "Boyle on gauge pressure: the ambient pressure without p_atm"),
    M("relief-law", "physics/gas.py",
      "np.maximum(n - (pressure + relief) * capacity / RT, 0.0)",
      "np.maximum(n - pressure * capacity / RT, 0.0)",
      "the venting law ignores the relief setting"),
    M("holding-rate-saturation", "physics/seabed.py",
      "return -(H0 / seabed.breakout_time) * min(uplift / H0, 1.0)",
      "return -(H0 / seabed.breakout_time) * (uplift / H0)",
      "holding decay without the min(U/H0, 1) saturation"),
    M("release-euler", "physics/seabed.py",
      "return holding * np.exp(-dt / release_time)",
      "return holding * (1.0 - dt / release_time)",
      "released suction by an Euler step instead of the exact exponential"),
    M("contact-pulls", "physics/seabed.py",
      "q * np.logical_or(bilateral, (w < 0.0) & (q > 0.0))",
      "q * np.logical_or(bilateral, w < 0.0)",
      "the one-sided seabed pulls a strip lifting off fast"),
    M("breakout-threshold", "physics/seabed.py",
      "COMPLETE_FRACTION = 1e-3", "COMPLETE_FRACTION = 1e-2",
      "breakout complete at 1 % of H0 instead of 0.1 %"),
    M("added-mass-law", "physics/hydro.py",
      "ca * rho * math.pi * breadth**2 / 4.0", "ca * rho * math.pi * breadth**2",
      "added mass C_a rho pi B^2 (the /4 lost)"),
    M("drag-law-abs", "physics/hydro.py",
      "return -coeff * np.abs(v) * v", "return -coeff * v * v",
      "drag -c v^2: pushes down on a sinking body"),
    M("submerged-weight-law", "physics/hydro.py",
      "return mass * g * (1.0 - rho_water / rho_structure)", "return mass * g",
      "submerged weight without the steel's own buoyancy"),
    # ------------------------------------------------------------------ the assembled plant
    M("hull-drag-breadth", "ascent/plant.py",
      "hydro.drag_coefficient(rho, hy.drag_coefficient, hull.breadth)",
      "hydro.drag_coefficient(rho, hy.drag_coefficient, hull.depth)",
      "hull strip drag on the depth instead of the breadth"),
    M("bag-drag-coefficient", "ascent/plant.py",
      "rho, hy.bag_drag_coefficient, 1.0)", "rho, hy.drag_coefficient, 1.0)",
      "bag drag with the hull's C_D (1.2) instead of C_D,bag (1.0)"),
    M("supply-derating", "ascent/kernel.py",
      "demand += state.fill[i] * switches.supply[i] * p / bags.p_atm",
      "demand += state.fill[i] * switches.supply[i]",
      "the compressor's share not derated by depth (free air counted at the bag's pressure)"),
    M("added-mass-plant", "ascent/plant.py",
      "mass_line = hydro.moving_water_per_length(",
      "mass_line = 0.0 * hydro.moving_water_per_length(",
      "the simulation's modes without the added mass (dry)"),
    M("modal-damping", "ascent/plant.py",
      "damping=2.0 * scenario.hull.modal_damping * modes.omega[:nr]",
      "damping=scenario.hull.modal_damping * modes.omega[:nr]",
      "modal damping zeta omega instead of 2 zeta omega"),
    M("dry-weight-plant", "ascent/plant.py",
      "wet_line = hull.wet_weight_per_length(g, rho, rho_s)[el]",
      "wet_line = hull.mass_per_length[el] * g",
      "the simulated hull carries its dry weight (steel buoyancy lost)"),
    M("open-bag-relief", "ascent/plant.py",
      "out = dict(relief=np.where(external, 0.0, gas_relief), kind=kind,",
      "out = dict(relief=np.full(nb, gas_relief), kind=kind,",
      "the paper's external bags hold over-pressure: no spill at capacity"),
    M("open-parachute-relief", "ascent/plant.py",
      "relief = 0.0 if kind_ext == BAG_OPEN_PARACHUTE else (",
      "relief = gas_relief if kind_ext == BAG_OPEN_PARACHUTE else (",
      "open parachute bags relieve like closed ones: no spill from the mouth"),
    M("paper-tributary-load", "ascent/paper.py",
      "force=force * trib[None, :]", "force=force.copy()",
      "the paper's bags feel one metre of hull drag and contact, not their tributary length"),
    M("paper-weight-share", "ascent/paper.py",
      "W = net_weight * trib / L", "W = net_weight * np.full(ne, 1.0 / ne)",
      "the paper's bags carry equal shares of the wet weight, not tributary shares"),
    # ------------------------------------------------------------------ loads in the loop
    M("hull-drag-sign", "ascent/mechanics.py",
      "drag(wvs - current, coeff[s])", "drag(current - wvs, coeff[s])",
      "hull drag along the relative motion instead of against it"),
    M("bag-drag-sign", "ascent/mechanics.py",
      "+ drag(zd[i] - current, bags.drag[i])", "- drag(zd[i] - current, bags.drag[i])",
      "bag drag along the motion instead of against it"),
    M("buoyancy-capacity", "ascent/mechanics.py",
      "point[i] = (buoyancy(volume[i], bags.rho_g)", "point[i] = (buoyancy(bags.capacity[i], bags.rho_g)",
      "bags lift their full capacity, not their gas volume"),
    M("sling-break", "ascent/mechanics.py",
      "bags.drag[i])) * attached[i]", "bags.drag[i]))",
      "a broken sling's bag still lifts the hull"),
    M("contact-always-bilateral", "ascent/mechanics.py",
      "contact_load(ws, wvs, k, c, held)", "contact_load(ws, wvs, k, c, True)",
      "the seabed holds the hull down after separation (bilateral contact)"),
    M("suction-sign", "ascent/mechanics.py",
      "load -= holding[g] * hold[s]", "load += holding[g] * hold[s]",
      "the released suction pulls the hull up"),
    M("contact-damping-implicit", "ascent/mechanics.py",
      "damp[i, j] += fi * strips.contact_c[s] * sj",
      "damp[i, j] += 0.0 * fi * strips.contact_c[s] * sj",
      "the seabed's damper left out of the implicit step"),
    M("trapezoidal-position", "ascent/mechanics.py",
      "q[i] += h * v[i] + 0.5 * h * dv", "q[i] += h * v[i] + h * dv",
      "position advanced with the end velocity, not the trapezoidal average"),
    M("trapezoidal-stiffness-velocity", "ascent/mechanics.py",
      "work[i] = h * s - 0.5 * h * h * kv", "work[i] = h * s",
      "the trapezoidal rule's -h^2/2 K v term dropped (first order)"),
    M("row-correction-bags", "ascent/recording.py",
      "    matvec_add(bags.corr_shape, f_point, z)\n", "",
      "the recorded heights without the eliminated modes' response to the bag forces"),
    M("uplift-sling", "ascent/recording.py",
      "total += bags.rho_g * volume[i] * attached[i]", "total += bags.rho_g * volume[i]",
      "the hold's uplift still counts a broken sling's bag"),
    # ------------------------------------------------------------------ gas and hold in the loop
    M("purge-orifice-loop", "ascent/kernel.py",
      "purge = _purge(plant, i, state.opening[i], state.V[i])",
      "purge = state.opening[i] * plant.bags.purge_max[i]",
      "the loop's start-of-step purge flow without the orifice law"),
    M("purge-closed-below-half", "ascent/kernel.py",
      "    if opening <= 0.0:\n        return 0.0", "    if opening <= 0.5:\n        return 0.0",
      "a valve opened less than half way purges nothing"),
    M("purge-account-end-only", "ascent/kernel.py",
      "if purge0 != 0.0 or purge1 != 0.0:", "if purge1 != 0.0:",
      "a step whose purge closed by its end leaves its purged gas out of the accounts"),
    M("boyle-loop", "ascent/kernel.py",
      "p1 = ambient_pressure(state.z[i], bags.water_depth, bags.p_atm, bags.rho_g)",
      "p1 = state.p[i]",
      "the gas pressure not updated as the bag rises: no expansion"),
    M("heun-euler", "ascent/kernel.py",
      "return max(state.n[i] + 0.5 * dt * (state.ndot[i] + ndot1), 0.0)",
      "return max(state.n[i] + dt * state.ndot[i], 0.0)",
      "gas stepped by explicit Euler instead of Heun"),
    M("leak-loop", "ascent/kernel.py",
      "(moles_rate(state.p[i], fill, purge, plant.bags.RT)\n                         - switches.leak[i] * state.n[i])",
      "(moles_rate(state.p[i], fill, purge, plant.bags.RT))",
      "a ruptured bag's leak left out of the start-of-step rate"),
    M("relief-loop", "ascent/kernel.py",
      "vented_moles(n, p, plant.bags.capacity[i], plant.bags.relief[i], plant.bags.RT)",
      "vented_moles(n, p, plant.bags.capacity[i], 0.0, plant.bags.RT)",
      "closed bags vent at ambient pressure: relief setting ignored by the loop"),
    M("holding-rate-loop", "ascent/kernel.py",
      "rate = holding_rate(state.gap[g] + state.H_old[g], state.H_old[g],",
      "rate = holding_rate(state.gap[g], state.H_old[g],",
      "the hold decays under uplift minus hold instead of the uplift"),
    M("separation-interpolation", "ascent/kernel.py",
      "th = min(max(g0 / (g0 - gap), 0.0), 1.0) if g0 <= 0.0 else 0.0", "th = 1.0",
      "separation at the end of its step, not located inside it"),
    # ------------------------------------------------------------------ faults
    M("supply-failure", "ascent/faults.py",
      "sw.supply[i] = 0.0", "sw.supply[i] = 1.0",
      "a supply failure has no effect"),
    M("fill-valve-stuck-closed", "ascent/faults.py",
      'elif fault.kind in ("supply_failure", "fill_valve_stuck_closed"):',
      'elif fault.kind == "supply_failure":',
      "a fill valve stuck closed has no effect: the bag fills on"),
    M("rupture-rate", "ascent/faults.py",
      "sw.leak[i] = 1.0 / fault.leak_time_s", "sw.leak[i] = 0.5 / fault.leak_time_s",
      "a ruptured bag leaks at half the rate of its leak time"),
    # ------------------------------------------------------------------ control
    M("pitch-rate-sign", "control/controller.py",
      "+ controllers.k_pitch_rate * xzd / xx", "- controllers.k_pitch_rate * xzd / xx",
      "coordinated pitch-rate feedback with the wrong sign"),
    M("pitch-angle-sign", "control/controller.py",
      "corr = controllers.k_pitch * xz / xx", "corr = -controllers.k_pitch * xz / xx",
      "coordinated pitch-angle feedback with the wrong sign"),
    M("fill-deadband", "control/controller.py",
      "if eps > controllers.deadband else 0.0", "if eps > 0.0 else 0.0",
      "fill starts within the deadband"),
    M("purge-anti-windup", "control/controller.py",
      "hold = (raw >= 1.0 and excess > 0.0) or not on", "hold = not on",
      "purge integral winds up while the valve is saturated"),
    M("sifsmc-slope", "control/controller.py",
      "(control_state.eps_rate[i] + controllers.lam * eps) * gain",
      "(control_state.eps_rate[i] + eps) * gain",
      "SIFSMC sliding variable without the slope lambda"),
    M("adapted-neutral-volume", "control/controller.py",
      "control_state.V_d[i] = (controllers.V_neutral[i] + control_state.adapt[i]\n",
      "control_state.V_d[i] = (controllers.V_neutral[i]\n",
      "the adapted neutral volume left out of V_d"),
    M("speed-filter", "control/controller.py",
      "control_state.zd_f[i] += a * (zd[i] - control_state.zd_f[i])",
      "control_state.zd_f[i] = zd[i]",
      "measured speed not filtered"),
    M("supervisor-rate-sign", "control/controller.py",
      "(vel - control_state.zd_f[i]) / controllers.r_scale",
      "(control_state.zd_f[i] - vel) / controllers.r_scale",
      "the supervisor's rate input with the wrong sign"),
    # ------------------------------------------------------------------ the staged lift
    M("stage-start-ignored", "control/controller.py",
      "control_state.started[i] = t >= controllers.start[i] - 1e-9",
      "control_state.started[i] = True",
      "every bag of a staged lift pulls from the start"),
    M("stretch-hold-normalisation", "ascent/plant.py",
      "hold_s = shape / frac[strip_group]", "hold_s = shape",
      "a stage's suction not normalised to its own stretch"),
    M("contact-update-sign", "ascent/mechanics.py",
      "sign = 1.0 if active[s] else -1.0", "sign = 1.0",
      "a strip leaving the seabed adds its spring instead of taking it away"),
    M("strength-span-end", "ascent/strength.py",
      "q[:, cols] += (lift", "q[:, cols[:-1]] += (lift",
      "an internal bag's buoyancy left off its span's last point"),
    M("seabed-load-centroid", "ascent/strength.py",
      "spread = 1.0 + 12.0 * (xs[cell] - mid) * (xe - mid) / wid**2",
      "spread = 1.0 + 0.0 * (xs[cell] - mid) * (xe - mid) / wid**2",
      "the strength spreads each strip's seabed load evenly over its cell (centroid off the strip)"),
    M("strength-moment-weights", "ascent/strength.py",
      "dM = Vq[r, j] * h + h * h * (q[r, j] / 3.0 + q[r, j + 1] / 6.0)",
      "dM = Vq[r, j] * h + h * h * (q[r, j] / 6.0 + q[r, j + 1] / 3.0)",
      "the compiled strength weights the moment of a linear load's two ends the wrong way"),
    M("valve-pass-square", "control/profile.py",
      "s = math.sqrt(prev * prev + step)", "s = math.sqrt(prev + step)",
      "the valve-limited profile's passes grow the speed with v, not v^2"),
    # ------------------------------------------------------------- step control (issue 28)
    M("held-block-in-fill", "ascent/kernel.py",
      "if (state.fill[i] != 0.0 or state.opening[i] != 0.0 or switches.leak[i] != 0.0",
      "if (state.opening[i] != 0.0 or switches.leak[i] != 0.0",
      "held blocks start while a bag is still filling"),
    M("quiet-step-no-hold", "ascent/kernel.py",
      "    holding(t, plant, state, switches, settings, recorder, switches.noise[0])",
      "    pass",
      "a quiet block's inner steps leave the holding force and separation unstepped"),
    M("separation-keeps-quiet", "ascent/kernel.py",
      "state.counters[1] &= ~(F_HAVE_B | F_QUIET)", "state.counters[1] &= ~F_HAVE_B",
      "a separation at a block's whole step leaves its other steps quiet (frozen)"),
    M("fault-outside-block", "ascent/loop.py",
      "Outside a block: nothing.\n        if self.state.counters[1] & F_HELD:\n",
      "Outside a block: nothing.\n        if True:\n",
      "a fault outside a held block restarts the force extrapolation all the same"),
    M("fault-keeps-block", "ascent/loop.py",
      "~(F_HELD | F_QUIET | F_STILL | F_HAVE_B)\n        self.fault_events.append(",
      "~(F_QUIET | F_STILL)\n        self.fault_events.append(",
      "a fault inside a held block leaves the block's mechanics frozen to its end"),
    M("free-strip-contact-skipped", "ascent/mechanics.py",
      "        if held or ws < 0.0:\n", "        if held:\n",
      "a free strip pressed into the seabed (a resettle, a touchdown) gets no contact"),
    M("still-hold-not-restarted", "ascent/kernel.py",
      "    if state.counters[1] & F_STILL:\n        hold_start(plant, state, switches)\n",
      "    if state.counters[1] & F_STILL:\n        pass\n",
      "a quiet block's later inner steps step the hold from a stale start"),
    M("still-never-cleared", "ascent/kernel.py",
      "    state.counters[1] &= ~F_STILL\n", "",
      "a quiet block's first inner step takes the state of the block before it"),
    M("row-line-zero-sign", "ascent/recording.py",
      "return a == b and (a != 0.0 or math.copysign(1.0, a) == math.copysign(1.0, b))",
      "return a == b",
      "a row whose line differs from the last row's by a zero's sign reuses its forces"),
    M("row-line-flag-ignored", "ascent/recording.py",
      "    same = bool(state.counters[1] & F_ROW_LINE)\n", "    same = True\n",
      "the first row takes forces nobody computed"),
    M("strip-pair-starts-negative-zero", "ascent/linalg.py",
      "        out_x[i] = 0.0\n", "        out_x[i] = -0.0\n",
      "a strip's motion of zero products reads -0.0 where matvec's reads +0.0"),
    M("strip-shape-t-paper-rows", "ascent/paper.py",
      "shape_t=np.ascontiguousarray(shape.T)", "shape_t=np.ascontiguousarray(shape.T[::-1])",
      "the paper plant's strips move by another mode's shape"),
    M("pitch-tan-doubled", "ascent/kernel.py",
      "    if slope > state.scalars[5]:\n", "    if slope > 2.0 * state.scalars[5]:\n",
      "the pitch's atan skipped at a new largest |tan| below twice the last"),
    M("release-step-two-steps", "ascent/loop.py",
      "release_step=float(released_holding(1.0, dt, seabed.release_time))",
      "release_step=float(released_holding(1.0, 2.0 * dt, seabed.release_time))",
      "a released hold decays two steps' worth at every step"),
    M("peak-limit-ignored", "ascent/kernel.py",
      "        if value > limit and not state.counters[1] & flag:\n", "        if False:\n",
      "no speed or pitch limit event is ever logged"),
    # ------------------------------------------------------------------ a case's Python
    M("checksum-section-width", "scenario/file.py",
      "len(line) <= _WIDTH - _INDENT", "len(line) <= 10**6",
      "a section's YAML put together from its keys' texts however long their lines"),
    M("geometry-salt-bags", "sweep/plants.py",
      "for name in GEOMETRY_READS)", "for name in GEOMETRY_READS if name != \"bags\")",
      "a kept plant geometry served to a plan whose bags differ"),
    M("forkserver-left-running", "cli/__init__.py",
      "            executors.stop_forkserver()\n", "            pass\n",
      "a refused sweep leaves its workers' fork server running"),
)


@dataclass
class Outcome:
    name: str
    file: str
    description: str
    outcome: str  # killed, survived, timeout, error
    seconds: float
    first_failure: str  # the first failing test (or why it is an error)


def copy_tree(dest: Path) -> None:
    """src/, tests/, pyproject.toml (the pytest settings) and the benchmarks' scenario files
    (some tests run them) of the checkout into ``dest``, without compiled or cached files."""
    skip = shutil.ignore_patterns("__pycache__", "*.pyc", "*.nbi", "*.nbc", ".pytest_cache",
                                  ".hypothesis", "*.egg-info")
    for name in ("src", "tests"):
        shutil.copytree(ROOT / name, dest / name, ignore=skip)
    shutil.copy2(ROOT / "pyproject.toml", dest / "pyproject.toml")
    (dest / "benchmarks").mkdir()
    for scenario in (ROOT / "benchmarks").glob("*.yaml"):
        shutil.copy2(scenario, dest / "benchmarks" / scenario.name)


def apply(mutation: Mutation, dest: Path) -> None:
    """Write ``mutation`` into the copy at ``dest``; ValueError unless its original occurs
    exactly once."""
    path = dest / "src" / "flexlift" / mutation.file
    text = path.read_text()
    count = text.count(mutation.original)
    if count != 1:
        raise ValueError(f"{mutation.name}: the original occurs {count} times in {mutation.file}")
    path.write_text(text.replace(mutation.original, mutation.replacement))


def environment(dest: Path) -> dict:
    env = dict(os.environ)
    env.update(PYTHONPATH=str(dest / "src"), NUMBA_CACHE_DIR=str(dest / "numba-cache"),
               MPLBACKEND="Agg", PYTHONDONTWRITEBYTECODE="1")
    env.pop("NUMBA_DISABLE_JIT", None)
    return env


def imported_from(dest: Path) -> str:
    """Where ``import flexlift`` finds the package with the copy's environment."""
    out = subprocess.run([sys.executable, "-c", "import flexlift; print(flexlift.__file__)"],
                         cwd=dest, env=environment(dest), capture_output=True, text=True,
                         check=True)
    return out.stdout.strip()


def first_failure(output: str) -> str:
    for line in output.splitlines():
        m = re.match(r"(FAILED|ERROR) (\S+)", line)
        if m:
            return m.group(2)
    return ""


def run_one(mutation: Mutation | None, tests, timeout: float, keep: bool) -> Outcome:
    """Copy, mutate, check the import, run the tests; the outcome with its time."""
    t0 = time.monotonic()
    name = mutation.name if mutation else "(unmutated)"
    dest = Path(tempfile.mkdtemp(prefix=f"flexlift-mutant-{name.strip('()')}-"))
    info = (mutation.file, mutation.description) if mutation else ("", "the code as it is")
    try:
        copy_tree(dest)
        if mutation:
            apply(mutation, dest)
        where = Path(imported_from(dest)).resolve()
        if where != (dest / "src" / "flexlift" / "__init__.py").resolve():
            raise RuntimeError(f"flexlift imported from {where}, not from the mutant's copy")
        cmd = [sys.executable, "-m", "pytest", "-x", "-q", "-p", "no:cacheprovider", *tests]
        try:
            proc = subprocess.run(cmd, cwd=dest, env=environment(dest), capture_output=True,
                                  text=True, timeout=timeout)
        except subprocess.TimeoutExpired:
            return Outcome(name, *info, "timeout", time.monotonic() - t0, f"over {timeout:.0f} s")
        out = proc.stdout + proc.stderr
        if proc.returncode == 0:
            outcome = "survived"
        elif proc.returncode == 1:
            outcome = "killed"
        else:
            outcome = "error"
        detail = first_failure(out) or (out.strip().splitlines() or [""])[-1]
        return Outcome(name, *info, outcome, time.monotonic() - t0, detail)
    except (ValueError, RuntimeError, subprocess.CalledProcessError) as e:
        return Outcome(name, *info, "error", time.monotonic() - t0, str(e).splitlines()[0])
    finally:
        if keep:
            print(f"  kept {dest}", flush=True)
        else:
            shutil.rmtree(dest, ignore_errors=True)


def measured_code() -> str:
    """The commit whose src/ and tests/ were mutated (and whether they had local changes)."""
    try:
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, check=True,
                              capture_output=True, text=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "src", "tests"], cwd=ROOT,
                               check=True, capture_output=True, text=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown (not a git checkout)"
    return head + (" with uncommitted changes" if dirty else "")


def score(results) -> dict:
    killed = sum(r.outcome in ("killed", "timeout") for r in results)
    return {"killed": killed, "total": len(results),
            "score_pct": round(100.0 * killed / max(len(results), 1), 1),
            "survived": [r.name for r in results if r.outcome == "survived"],
            "errors": [r.name for r in results if r.outcome == "error"]}


def write_report(args, base, results, total: float, finished: bool) -> None:
    """``args.json``: the code measured, the score so far and each mutant's outcome;
    ``finished`` is false while mutants are still to run."""
    report = {"code": measured_code(), "tests": list(args.tests),
              "python": sys.version.split()[0], "finished": finished,
              "unmutated_seconds": round(base.seconds, 1), "total_seconds": round(total, 1),
              **score(results),
              "mutations": [{**asdict(r), "seconds": round(r.seconds, 1)} for r in results]}
    tmp = Path(args.json).with_suffix(".json.partial")
    tmp.write_text(json.dumps(report, indent=2) + "\n")
    tmp.replace(args.json)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", nargs="+", metavar="NAME", help="run only these mutations")
    ap.add_argument("--list", action="store_true", help="list the mutations and check that "
                    "each original occurs exactly once; run nothing")
    ap.add_argument("--tests", nargs="+", default=list(TESTS), help="the test files to run")
    ap.add_argument("--json", default=str(ROOT / "benchmarks" / "mutation.json"))
    ap.add_argument("--keep", action="store_true", help="keep the mutants' folders")
    args = ap.parse_args(argv)
    chosen = [m for m in MUTATIONS if not args.only or m.name in args.only]
    if args.only and len(chosen) != len(set(args.only)):
        known = {m.name for m in MUTATIONS}
        ap.error(f"unknown mutations: {', '.join(sorted(set(args.only) - known))}")
    if args.list:
        bad = 0
        for m in chosen:
            n = (ROOT / "src" / "flexlift" / m.file).read_text().count(m.original)
            bad += n != 1
            print(f"{m.name:32s} {m.file:24s} {'ok' if n == 1 else f'FOUND {n} TIMES'}  "
                  f"{m.description}")
        return 1 if bad else 0

    print(f"mutation check: {len(chosen)} mutations, tests: {' '.join(args.tests)}", flush=True)
    base = run_one(None, args.tests, timeout=3600.0, keep=False)
    verdict = "passed" if base.outcome == "survived" else f"{base.outcome}: {base.first_failure}"
    print(f"unmutated: {verdict} in {base.seconds:.0f} s", flush=True)
    if base.outcome != "survived":
        print("the unmutated code must pass its tests first", file=sys.stderr)
        return 2
    timeout = max(600.0, 4.0 * base.seconds)
    results = []
    t0 = time.monotonic()
    for k, m in enumerate(chosen, 1):
        r = run_one(m, args.tests, timeout, args.keep)
        results.append(r)
        print(f"[{k:2d}/{len(chosen)}] {r.outcome:8s} {r.seconds:5.0f} s  {m.name:32s} "
              f"{r.first_failure}", flush=True)
        # after every mutant, so a run stopped part-way keeps what it measured
        write_report(args, base, results, time.monotonic() - t0, finished=k == len(chosen))
    total = time.monotonic() - t0
    s = score(results)
    print()
    print("| mutation | file | outcome | s | first failing test |")
    print("|---|---|---|---|---|")
    for r in results:
        print(f"| {r.name} | {r.file} | {r.outcome} | {r.seconds:.0f} | {r.first_failure} |")
    print(f"\nscore: {s['killed']} of {s['total']} killed ({s['score_pct']} %) in {total / 60:.0f} "
          f"min ({total / max(len(results), 1):.0f} s a mutant); unmutated run {base.seconds:.0f} s")
    if s["survived"]:
        print("survived: " + ", ".join(s["survived"]))
    print(f"wrote {args.json}")
    return 0 if not s["errors"] else 1


if __name__ == "__main__":
    sys.exit(main())
