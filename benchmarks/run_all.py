"""Run every benchmark in this folder and write the results to benchmarks/results.json.

Each ``bench_*.py`` module exposes ``run(quick: bool = False) -> dict`` returning its
measurements (times in seconds, memory in bytes, and ratios against the peer library measured
in the same run). ``python benchmarks/run_all.py [--quick] [NAME ...]``.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import platform
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("names", nargs="*", help="benchmarks to run (default: all), e.g. modes")
    ap.add_argument("--quick", action="store_true", help="smaller sizes, for a smoke run")
    ap.add_argument("--out", type=Path, default=HERE / "results.json")
    args = ap.parse_args(argv)
    files = sorted(HERE.glob("bench_*.py"))
    if args.names:
        files = [f for f in files if f.stem.removeprefix("bench_") in args.names]
    results = {}
    if args.out.exists():
        results = json.loads(args.out.read_text()).get("benchmarks", {})
    for f in files:
        spec = importlib.util.spec_from_file_location(f.stem, f)
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
        name = f.stem.removeprefix("bench_")
        print(f"[bench] {name} ...", file=sys.stderr, flush=True)
        t0 = time.perf_counter()
        results[name] = mod.run(quick=args.quick)
        results[name]["wall_s"] = round(time.perf_counter() - t0, 2)
        print(json.dumps({name: results[name]}, indent=2))
    doc = {
        "machine": {"python": platform.python_version(), "platform": platform.platform()},
        "date": time.strftime("%Y-%m-%d"),
        "benchmarks": results,
    }
    args.out.write_text(json.dumps(doc, indent=2) + "\n")
    print(f"[bench] wrote {args.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
