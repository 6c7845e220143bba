"""Every mutant of the mutation check (benchmarks/mutate.py) still applies to the code: its
original text occurs exactly once in its file. A rename that moves a law away from its mutant
would otherwise leave the law unguarded until the next hour-long ``./dev mutate``."""

import importlib.util
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("mutate", ROOT / "benchmarks" / "mutate.py")
mutate = importlib.util.module_from_spec(_spec)
sys.modules.setdefault("mutate", mutate)  # its dataclasses look their module up
_spec.loader.exec_module(mutate)


@pytest.mark.parametrize("mutation", mutate.MUTATIONS, ids=lambda m: m.name)
def test_the_mutant_applies(mutation):
    text = (ROOT / "src" / "flexlift" / mutation.file).read_text()
    assert text.count(mutation.original) == 1, mutation.name
    assert mutation.replacement != mutation.original
