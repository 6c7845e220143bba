"""The README's Quick start, API example and scenario reference stay true."""

import re
from pathlib import Path

from pydantic import BaseModel

from flexlift.scenario import Scenario

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()


def _section(title: str) -> str:
    m = re.search(rf"^## {title}\n(.*?)(?=^## )", README, flags=re.S | re.M)
    assert m, f"README has no '## {title}' section"
    return m.group(1)


def _code_blocks(text: str, lang: str) -> list[str]:
    return re.findall(rf"```{lang}\n(.*?)```", text, flags=re.S)


def test_quick_start_has_exactly_the_two_commands():
    blocks = _code_blocks(_section("Quick start"), "bash")
    assert len(blocks) == 1
    commands = [ln.split("#")[0].strip() for ln in blocks[0].splitlines() if ln.strip()]
    assert commands == ["./dev run", "./dev test"]
    dev = (ROOT / "dev").read_text()
    assert 'exec "$venv/bin/flexlift" run' in dev  # `./dev run` is `flexlift run`
    assert (ROOT / ".ci" / "run").read_text().rstrip().endswith("exec ./dev test")


def test_python_api_example_runs(capsys):
    blocks = _code_blocks(_section("Python API"), "python")
    assert blocks, "the API section has a python example"
    assert len(blocks[0].strip().splitlines()) <= 14
    exec(compile(blocks[0], "README.md", "exec"), {})
    printed = capsys.readouterr().out.split()
    assert printed[0] == "unsorted_mdc"
    assert abs(float(printed[1])) < 0.01  # % gain error of the 4-state mdc model


def _leaf_keys(model: type[BaseModel], prefix=""):
    for name, field in model.model_fields.items():
        ann = field.annotation
        if isinstance(ann, type) and issubclass(ann, BaseModel):
            yield from _leaf_keys(ann, f"{prefix}{name}.")
        else:
            yield f"{prefix}{name}"


def test_every_scenario_key_is_documented():
    text = _section("Scenario format")
    missing = [k for k in _leaf_keys(Scenario) if f"`{k.split('.')[-1]}" not in text
               and f".{k.split('.')[-1]}`" not in text and f"{k.split('.')[-1]}`" not in text]
    assert not missing, f"README's scenario table lacks: {missing}"
