"""Hostile scenario files and values: one line naming the problem, exit 2, never a traceback
or a hang (issue 10). Most cases here were a traceback, a hang or a silent acceptance before;
the others guard what must keep working (a symlink to a file, a UTF-8 byte-order mark, YAML
merge keys, names such as ``.hidden``)."""

import math
import os
import re
import sys
import time
import typing

import annotated_types as at
import numpy as np
import pytest
from pydantic import BaseModel

from flexlift import load_scenario
from flexlift.cli import main
from flexlift.errors import InputError
from flexlift.scenario import Scenario, parse_scenario

#: the documented limits of a scenario file (docs/reference/scenario.md)
MAX_BYTES = 1_000_000
MAX_DEPTH = 32


def _write(tmp_path, content, name="s.yaml"):
    p = tmp_path / name
    if isinstance(content, bytes):
        p.write_bytes(content)
    else:
        p.write_text(content, encoding="utf-8")
    return p


def _refused(path_or_data, *needles, limit=300):
    """The InputError of loading ``path_or_data`` (a path or a mapping): one line starting
    with the file's name, at most ``limit`` characters after it, holding every needle."""
    with pytest.raises(InputError) as e:
        if isinstance(path_or_data, dict):
            parse_scenario(path_or_data)
        else:
            load_scenario(path_or_data)
    msg = str(e.value)
    source = "scenario" if isinstance(path_or_data, dict) else str(path_or_data)
    assert "\n" not in msg and "\r" not in msg, msg
    assert msg.startswith(source + ": ") and len(msg) - len(source) <= limit, msg
    for n in needles:
        assert n in msg, msg
    return msg


def _cli_one_line(capsys, args, *needles):
    assert main(args) == 2
    cap = capsys.readouterr()
    lines = cap.err.splitlines()
    assert len(lines) == 1 and cap.err.endswith("\n") and "Traceback" not in cap.err, cap.err
    for n in needles:
        assert n in lines[0], lines[0]
    return lines[0]

# --------------------------------------------------------------------------- not a regular file
def test_a_folder_is_not_a_scenario(tmp_path, capsys):
    d = tmp_path / "s.yaml"
    d.mkdir()
    _refused(d, "a folder, not a scenario file")
    _cli_one_line(capsys, ["loads", str(d)], "a folder")


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="FIFOs are POSIX")
def test_a_fifo_is_refused_without_waiting_for_a_writer(tmp_path):
    p = tmp_path / "pipe.yaml"
    os.mkfifo(p)
    t0 = time.perf_counter()
    _refused(p, "a FIFO (named pipe), not a regular file")
    assert time.perf_counter() - t0 < 5


@pytest.mark.skipif(not os.path.exists("/dev/zero"), reason="needs /dev/zero")
def test_a_device_is_refused():
    _refused("/dev/zero", "/dev/zero: a character device, not a regular file")


@pytest.mark.skipif(sys.platform == "win32", reason="symbolic links need privileges on Windows")
def test_a_symlink_loop_is_named_as_such(tmp_path):
    (tmp_path / "a.yaml").symlink_to(tmp_path / "b.yaml")
    (tmp_path / "b.yaml").symlink_to(tmp_path / "a.yaml")
    _refused(tmp_path / "a.yaml", "a symbolic link that loops")


def test_a_symlink_to_a_good_file_is_followed(tmp_path):
    target = _write(tmp_path, "name: linked\n", "real.yaml")
    (tmp_path / "link.yaml").symlink_to(target)
    assert load_scenario(tmp_path / "link.yaml").name == "linked"


@pytest.mark.parametrize("error, needle", [
    (PermissionError(13, "Permission denied"), "permission denied; the scenario file must be readable"),
    (OSError(36, "File name too long"), "cannot be opened (File name too long)"),
])
def test_files_that_cannot_be_opened(tmp_path, monkeypatch, error, needle):
    p = _write(tmp_path, "name: x\n")

    def refuse(*args, **kw):
        raise error

    monkeypatch.setattr(os, "open", refuse)
    _refused(p, needle)


def test_missing_file_still_says_no_such_file(tmp_path):
    _refused(tmp_path / "nope.yaml", "no such file", "tanker")
    _refused(tmp_path / "nope" / "deeper.yaml", "no such file")


# --------------------------------------------------------------------------- size
def test_a_file_over_the_size_limit_is_refused_quickly(tmp_path):
    p = _write(tmp_path, "description: " + "x" * (50 * 1024 * 1024) + "\n")  # 50 MB: hung before
    t0 = time.perf_counter()
    _refused(p, "larger than 1,000,000 bytes (1 MB)")
    assert time.perf_counter() - t0 < 5


def test_a_file_just_under_the_limit_is_read(tmp_path):
    text = "name: big\n# padding\n"
    text += "#" * (MAX_BYTES - len(text) - 1) + "\n"
    assert len(text.encode()) == MAX_BYTES
    assert load_scenario(_write(tmp_path, text)).name == "big"


# --------------------------------------------------------------------------- encoding
@pytest.mark.parametrize(
    "content, needles",
    [
        (bytes(range(256)), ["a binary file", "NUL byte at line 1, column 1"]),
        ("name: tanker\n".encode("utf-16"), ["UTF-16 text", "save the scenario as UTF-8"]),
        ("description: caf\u00e9\n".encode("latin-1"),
         ["not UTF-8 text: byte 0xe9 at line 1, column 17", "save the scenario as UTF-8"]),
        (b"name: a\ndescription: \xff\xfe oops\n", ["byte 0xff at line 2, column 14"]),
    ],
    ids=["binary", "utf-16", "latin-1", "invalid-utf-8"],
)
def test_text_that_is_not_utf8(tmp_path, capsys, content, needles):
    p = _write(tmp_path, content)
    _refused(p, *needles)
    _cli_one_line(capsys, ["loads", str(p), "--json"], needles[0])


def test_utf8_with_a_byte_order_mark_and_accents_is_read(tmp_path):
    p = _write(tmp_path, "\ufeffname: epave\ndescription: \u00e9pave \u00e0 350 m\n")
    s = load_scenario(p)
    assert s.name == "epave" and s.description.startswith("\u00e9pave")


@pytest.mark.parametrize("text", ["", "\n\n   \n", "# only a comment\n", "~\n", "null\n", "---\n"])
def test_an_empty_file_is_refused_not_read_as_the_tanker(tmp_path, capsys, text):
    p = _write(tmp_path, text)
    _refused(p, "the file is empty", "is not read as the tanker", "name: tanker")
    _cli_one_line(capsys, ["modes", str(p), "--json"], "empty")


def test_name_tanker_is_the_tanker(tmp_path, tanker):
    """Every default is the tanker's, but for the lift plan a user's hull gets: the balanced
    layout and the breakout pull in proportion to the suction (the built-in tanker file keeps
    the paper's nodes of mode 3 and 150 t), and the schema's tilt limit, 2 deg (0027/ND 5.3.2 by
    analogy; the built-in file sets the paper's 15 deg and names its catalogue bag)."""
    again = load_scenario(_write(tmp_path, "name: tanker\n"))
    assert again.limits.pitch_deg == 2.0 and again.lift.catalogue_bag.model is None
    assert again.with_changes(**{"lift.layout": "mode_nodes", "control.breakout_pull_t": 150.0,
                                 "limits.pitch_deg": 15.0,
                                 "lift.catalogue_bag.model": "paper_cylinder_565t"}
                              ).model_dump(exclude={"description"}) == tanker.model_dump(
        exclude={"description"})
    assert again.lift.layout == "balanced" and again.control.breakout_pull_t is None


# --------------------------------------------------------------------------- YAML structure
def test_deep_flow_nesting_is_one_line(tmp_path, capsys):
    p = _write(tmp_path, "hull: " + "[" * 3000 + "]" * 3000 + "\n")  # a RecursionError before
    _refused(p, f"nesting deeper than {MAX_DEPTH} levels at line 1", "a scenario needs at most 5")
    _cli_one_line(capsys, ["loads", str(p)], "nesting deeper")


def test_deep_block_nesting_is_one_line(tmp_path):
    text = "hull:\n" + "".join(" " * (i + 1) + f"k{i}:\n" for i in range(1000))
    _refused(_write(tmp_path, text), f"nesting deeper than {MAX_DEPTH} levels at line {MAX_DEPTH + 1}")


def test_nesting_through_aliases_is_bounded(tmp_path):
    lines = ["faults:", "  - &a0 [[[[[[[[1]]]]]]]]"]
    lines += [f"  - &a{i} [[[[[[[[*a{i - 1}]]]]]]]]" for i in range(1, 6)]
    _refused(_write(tmp_path, "\n".join(lines) + "\n"), "nests deeper than", "alias *a")


def _bomb(use: str) -> str:
    """A billion laughs: anchors a0..a8, each ten of the one before, then ``use``."""
    lines = ["faults:", "  - &a0 [lol, lol, lol, lol, lol, lol, lol, lol, lol, lol]"]
    lines += [f"  - &a{i} [" + ", ".join([f"*a{i - 1}"] * 10) + "]" for i in range(1, 9)]
    return "\n".join(lines) + "\n" + use + "\n"


@pytest.mark.parametrize("use", ["description: *a8", "hull:\n  bending_stiffness_Nm2: *a8",
                                 "disturbance:\n  seed: *a8", "lift:\n  bags: *a8"])
def test_an_alias_bomb_in_a_real_field_is_refused_quickly(tmp_path, capsys, use):
    p = _write(tmp_path, _bomb(use))  # the error formatter expanded the value and never finished
    t0 = time.perf_counter()
    _refused(p, "more than 1,000,000 values once the aliases are expanded")
    assert time.perf_counter() - t0 < 5
    _cli_one_line(capsys, ["loads", str(p), "--json"], "aliases")


def test_moderate_aliases_still_work_and_echo_is_short(tmp_path):
    lines = ["faults:", "  - &a0 [x, x, x, x, x, x, x, x, x, x]"]
    lines += [f"  - &a{i} [" + ", ".join([f"*a{i - 1}"] * 10) + "]" for i in range(1, 4)]
    msg = _refused(_write(tmp_path, "\n".join(lines) + "\ndescription: *a3\n"), "description = [")
    assert len(msg) < 250  # the value is echoed in at most ~80 characters


def test_recursive_alias_is_refused(tmp_path):
    _refused(_write(tmp_path, "hull: &h\n  point_masses: [*h]\n"), "used inside its own anchor")


def test_merge_keys_are_not_duplicates(tmp_path):
    p = _write(tmp_path, "faults:\n  - &f {kind: sling_break, bag: bag_1, time_s: 10}\n"
               "  - {<<: *f, time_s: 20}\n")
    s = load_scenario(p)
    assert [f.time_s for f in s.faults] == [10, 20] and s.faults[1].bag == "bag_1"


@pytest.mark.parametrize(
    "text, needles",
    [
        ("hull:\n  elements: 11\n  elements: 40\n",
         ["duplicate key hull.elements at line 3, column 3 (first given at line 2)"]),
        ("hull:\n  elements: 11\nlift: {}\nhull:\n  elements: 40\n",
         ["duplicate key hull at line 4", "first given at line 1"]),
        ("faults:\n  - {kind: sling_break, bag: b, time_s: 1, time_s: 2}\n",
         ["duplicate key faults[0].time_s at line 2"]),
        ("name: a\n'name': b\n", ["duplicate key name at line 2"]),
    ],
)
def test_duplicate_keys_are_refused_with_key_and_line(tmp_path, text, needles):
    _refused(_write(tmp_path, text), *needles, "give each key once")  # the last one won before


@pytest.mark.parametrize(
    "text, shown",
    [
        ('hull:\n  "len\\ngth_m": 3\n', "hull.len\\ngth_m"),
        ('"hu\\nll": 3\n', "hu\\nll"),
        ('hull:\n  "len\\egth_m": 3\n', "len\\x1bgth_m"),
        ('hull:\n  "a\\u2028b": 3\n', "a\\u2028b"),
        ('hull:\n  ? "' + "k" * 5000 + '"\n  : 3\n', "kkk...kkk"),
    ],
    ids=["newline", "newline-top", "escape", "line-separator", "long"],
)
def test_strange_keys_are_escaped_on_one_line(tmp_path, capsys, text, shown):
    p = _write(tmp_path, text)
    msg = _refused(p, "unknown key", shown)
    assert "\x1b" not in msg and "\u2028" not in msg
    _cli_one_line(capsys, ["loads", str(p)], "unknown key")


@pytest.mark.parametrize("text, needle", [
    ("1: 2\n", "key 1 in the top level is not a name at line 1, column 1"),
    ("hull:\n  true: 3\n", "key true in hull is not a name at line 2, column 3"),
    ("hull:\n  [a, b]: 3\n", "key a list in hull is not a name"),
    ("? {a: 1}\n: 2\n", "key a mapping in the top level is not a name"),
])
def test_keys_that_are_not_names(tmp_path, text, needle):
    _refused(_write(tmp_path, text), needle)


@pytest.mark.parametrize("text, needles", [
    ("name: a\n---\nname: b\n", ["a second YAML document ('---') at line 2"]),
    ("name: a\x1b\n", ["character U+001B at line 1, column 8 is not allowed in YAML"]),
    ("disturbance:\n  seed: " + "9" * 5000 + "\n", ["an integer of 5000 characters", "line 2"]),
    ("hull: *nowhere\n", ["alias *nowhere with no anchor"]),
    ("hull: !!python/object:os.system {}\n", ["malformed YAML at line 1", "could not determine a "
                                             "constructor"]),
    ("a: &x 1\nb: &x 2\n", ["anchor &x defined twice at line 2"]),
])
def test_other_malformed_yaml_is_one_line(tmp_path, text, needles):
    _refused(_write(tmp_path, text), *needles)


def test_yaml_1_2_exponents_are_numbers(tmp_path):
    # PyYAML reads 1e12 as text; with strict numbers that would be refused
    s = load_scenario(_write(tmp_path, "based_on: tanker\nhull:\n  bending_stiffness_Nm2: 2e12\n  breadth_m: 1E1\n"
                             "disturbance:\n  current_m_s: -5.e-2\n  force_noise_N_m: .5e2\n"))
    assert s.hull.bending_stiffness_Nm2 == 2e12 and s.hull.breadth_m == 10.0
    assert s.disturbance.current_m_s == -0.05 and s.disturbance.force_noise_N_m == 50.0


# --------------------------------------------------------------------------- API edges
def test_parse_scenario_refuses_none_and_non_mappings():
    with pytest.raises(InputError, match="a scenario must be a mapping"):
        parse_scenario(None)
    with pytest.raises(InputError, match="a scenario must be a mapping"):
        parse_scenario([1, 2])


def test_with_changes_through_a_value_is_an_input_error(tanker):
    with pytest.raises(InputError, match="hull.elements is a value, not a section"):
        tanker.with_changes(**{"hull.elements.x": 3})
    with pytest.raises(InputError, match="unknown key 'hul'"):
        tanker.with_changes(**{"hul.x": 3})


def test_brief_and_clean_never_expand_or_break_lines():
    from flexlift.errors import brief, clean

    big = [[list(range(10))] * 1000] * 1000
    assert len(brief(big)) <= 80
    assert brief("a\nb") == "'a\\nb'" and "\n" not in brief({"k\n": "v\r"})
    loop: list = []
    loop.append(loop)
    assert brief(loop) == "[[[[...]]]]"
    assert brief(10**10000) == "<an integer of about 10001 digits>"
    assert clean("x\u2028y\x1b\u202ez") == "x\\u2028y\\x1b\\u202ez"
    assert len(clean("x" * 10**6, 50)) == 50


def test_text_that_reads_as_a_number_is_quoted_in_the_yaml(tmp_path, tanker):
    import yaml

    s = parse_scenario({"name": "1e5", "description": "2E-3"})
    p = _write(tmp_path, s.to_yaml())
    assert load_scenario(p) == s  # unquoted, 1e5 reads back as a number: no valid name
    # and the tanker's YAML (and so its checksum) is what PyYAML wrote before
    # (a scenario without sensors writes no sensors section: its text from before them)
    assert tanker.sensors is None
    # (nor a surfacing section without a final lift)
    assert tanker.to_yaml() == yaml.safe_dump(
        tanker.model_dump(mode="json", exclude={"sensors", "surfacing"}), sort_keys=False)


# --------------------------------------------------------------------------- numbers
def _leaves(model: type[BaseModel], prefix=""):
    for name, field in model.model_fields.items():
        ann = field.annotation
        if isinstance(ann, type) and issubclass(ann, BaseModel):
            yield from _leaves(ann, f"{prefix}{name}.")
        else:
            yield f"{prefix}{name}", field


def _constraints(obj):
    """Every annotated_types constraint in a field or annotation, however nested."""
    out = []
    if isinstance(obj, at.BaseMetadata):
        out.append(obj)
    for m in getattr(obj, "metadata", None) or ():
        out += _constraints(m)
    for m in getattr(obj, "__metadata__", ()):
        out += _constraints(m)
    for a in typing.get_args(getattr(obj, "annotation", obj)):
        out += _constraints(a)
    return out


def _is_numeric(field) -> bool:
    def numeric(t):
        return t in (int, float) or any(numeric(a) for a in typing.get_args(t))

    return numeric(field.annotation)


def _nest(key: str, value) -> dict:
    data: dict = {}
    node = data
    *path, last = key.split(".")
    for p in path:
        node = node.setdefault(p, {})
    node[last] = value
    return data


#: a valid item of each list of sections, to place one bad number in
_ITEMS = {
    "hull.point_masses": [{"node": 1, "mass_t": 1.0}],
    "lift.bags": [{"name": "b", "kind": "external", "node": 2},
                  {"name": "b", "kind": "external", "x_m": 1.0},
                  {"name": "b", "kind": "internal", "span_m": [1.0, 2.0]}],
    "faults": [{"kind": m.model_fields["kind"].annotation.__args__[0], "bag": "b", "time_s": 1.0}
               for m in typing.get_args(typing.get_args(Scenario.model_fields["faults"].annotation)[0])
               [0].__args__],
}


def _slots():
    """{label: (field, place)} for every number of the schema: ``place(v)`` is a scenario
    mapping with ``v`` in that number's place and everything else valid."""
    out = {}
    for key, field in _leaves(Scenario):
        if key in _ITEMS:
            for item in _ITEMS[key]:
                model = Scenario
                for part in key.split("."):
                    model = model.model_fields[part].annotation
                    while not (isinstance(model, type) and issubclass(model, BaseModel)):
                        args = [a for a in typing.get_args(model)
                                if isinstance(a, type) and issubclass(a, BaseModel)
                                and (a.model_fields.get("kind") is None or item.get("kind")
                                     in typing.get_args(a.model_fields["kind"].annotation))]
                        model = args[0] if args else typing.get_args(model)[0]
                for name, f in model.model_fields.items():
                    if not _is_numeric(f) or (name in ("x_m", "node", "span_m") and name not in item):
                        continue
                    label = f"{key}[0].{name}"
                    if "tuple" in str(f.annotation):
                        out[label + "[0]"] = (f, lambda v, k=key, i=item, n=name: _nest(
                            k, [{**i, n: [v, 2.0]}]))
                    else:
                        out[label] = (f, lambda v, k=key, i=item, n=name: _nest(k, [{**i, n: v}]))
        elif "tuple" in str(field.annotation):
            out[key + "[0]"] = (field, lambda v, k=key: _nest(k, [v, 113.0]))
        elif _is_numeric(field):
            out[key] = (field, lambda v, k=key: _nest(k, v))
    return out


SLOTS = _slots()
REAL = [k for k, (f, _) in SLOTS.items() if "float" in str(f.annotation)]


def test_the_key_walk_sees_every_number():
    assert len(SLOTS) >= 80, sorted(SLOTS)
    for k in ("hull.elements", "disturbance.seed", "hull.ballast_tank_frames[0]",
              "hull.point_masses[0].mass_t", "lift.bags[0].span_m[0]", "faults[0].leak_time_s",
              "faults[0].rate_m_s", "control.supervisor.resolution"):
        assert k in SLOTS, k
    assert "hull.bending_stiffness_Nm2" in REAL and "hull.elements" not in REAL
    assert "lift.bags[0].kind" not in SLOTS and "name" not in SLOTS


@pytest.mark.parametrize("label", sorted(SLOTS))
def test_every_number_is_bounded_below_and_above(label):
    kinds = {type(c) for c in _constraints(SLOTS[label][0])}
    assert kinds & {at.Ge, at.Gt} and kinds & {at.Le, at.Lt}, f"{label} has no range: {kinds}"


@pytest.mark.parametrize("label", sorted(REAL))
@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf])
def test_nan_and_infinity_are_refused_in_every_real_number(label, value):
    _refused(SLOTS[label][1](value), f"{label} = {value}: Input should be a finite number")


@pytest.mark.parametrize("label", sorted(SLOTS))
@pytest.mark.parametrize("value, needle", [(True, "not true/false"), (False, "not true/false"),
                                           ("12", "not text"), ("1e3", "not text")])
def test_booleans_and_text_are_not_numbers(label, value, needle):
    _refused(SLOTS[label][1](value), f"{label} = {value!r}: a number is needed here, {needle}")


def test_nan_in_yaml_current_was_accepted(tmp_path, capsys):
    p = _write(tmp_path, "disturbance:\n  current_m_s: .nan\n")  # passed, then exit 1 in numerics
    _refused(p, "disturbance.current_m_s = nan: Input should be a finite number")
    _cli_one_line(capsys, ["simulate", str(p), "--duration", "20", "--json"], "current_m_s")


def test_infinite_breakout_factor_was_an_overflow(tmp_path, capsys):
    p = _write(tmp_path, "lift:\n  breakout_factor: .inf\n")
    _cli_one_line(capsys, ["loads", str(p), "--json"], "lift.breakout_factor = inf")


def test_integers_are_real_numbers_and_whole_reals_are_integers():
    s = parse_scenario({"based_on": "tanker",
                        "hull": {"length_m": 78, "elements": 12.0, "bending_stiffness_Nm2": [3e12] * 12}})
    assert s.hull.length_m == 78.0 and isinstance(s.hull.length_m, float) and s.hull.elements == 12
    _refused({"hull": {"elements": 11.5}}, "hull.elements = 11.5", "fractional part")


def test_other_strict_types():
    _refused({"control": {"shape_breakout_pull": "yes"}}, "shape_breakout_pull")
    _refused({"control": {"shape_breakout_pull": 1}}, "shape_breakout_pull")
    _refused({"description": 2024}, "description = 2024")
    _refused({"name": b"bytes"}, "name = b'bytes'")


@pytest.mark.parametrize(
    "data, needles",
    [
        ({"hull": {"elements": 1_000_000_000}}, ["hull.elements = 1000000000", "less than or equal to 20000"]),
        ({"hull": {"elements": 10**29 + 7}}, ["hull.elements", "20000"]),
        ({"hull": {"elements": 10**5000}}, ["an integer of about 5001 digits"]),
        ({"hull": {"bending_stiffness_Nm2": 1e-300}}, ["bending_stiffness_Nm2 = 1e-300", "1000"]),
        ({"hull": {"bending_stiffness_Nm2": [1e12] * 10 + [1e17]}}, ["bending_stiffness_Nm2[10] = 1e+17"]),
        ({"disturbance": {"seed": -1}}, ["disturbance.seed = -1", "greater than or equal to 0"]),
        ({"control": {"supervisor": {"resolution": 10**9}}}, ["resolution", "10001"]),
        ({"simulation": {"duration_s": 1e15}}, ["duration_s"]),
        ({"simulation": {"time_step_s": 1e-4, "duration_s": 6000}}, ["6e+07 steps", "10,000,000"]),
        ({"simulation": {"output_interval_s": 0.01, "time_step_s": 0.01}}, ["6e+05 stored rows"]),
        ({"environment": {"steel_density_kg_m3": 1000}}, ["steel_density_kg_m3 = 1000", "1500"]),
        ({"hull": {"point_masses": [{"node": 10**30, "mass_t": 1}]}}, ["point_masses[0].node"]),
        ({"faults": [{"kind": "sling_break", "bag": "bag_1", "time_s": -1}]}, ["faults[0].time_s = -1"]),
        ({"faults": [{"kind": "explode", "bag": "bag_1", "time_s": 1}]}, ["faults[0]", "unknown kind 'explode'"]),
        ({"faults": [{"bag": "bag_1", "time_s": 1}]}, ["faults[0]", "needs a kind", "'sling_break'"]),
        ({"lift": {"bags": [{"name": "b", "kind": "external", "node": 2, "x_z": 1}]}},
         ["unknown key 'lift.bags[0].x_z'", "did you mean 'x_m'?", "valid keys here are: name, kind"]),
        ({"faults": [{"kind": "bag_rupture", "bag": "b", "time_s": 1, "leak": 3}]},
         ["unknown key 'faults[0].leak'", "leak_time_s"]),
        ({1: 2}, ["key 1 in the scenario is not a name"]),
    ],
)
def test_values_out_of_range_name_key_value_and_range(data, needles):
    _refused(data, *needles)


def test_sizes_that_could_not_fit_are_exit_2(tmp_path, capsys):
    for text, needle in (("hull:\n  elements: 1000000000\n", "hull.elements"),
                         ("hull:\n  elements: 123456789012345678901234567890\n", "hull.elements"),
                         ("hull:\n  bending_stiffness_Nm2: 1.0e-300\n", "bending_stiffness_Nm2")):
        _cli_one_line(capsys, ["modes", str(_write(tmp_path, text)), "--json"], needle)


def test_the_extremes_of_the_hull_ranges_still_compute(capsys):
    # a long thin pipe and a short stiff heavy block: both at the ends of every hull range
    import json

    from flexlift.structure.hull import hull_from_scenario
    from flexlift.structure.modes import compute_modes

    for hull in ({"length_m": 20_000.0, "bending_stiffness_Nm2": 1e3, "displacement_t": None,
                  "mass_per_length_kg_m": 0.01, "elements": 40},
                 {"length_m": 1.0, "bending_stiffness_Nm2": 1e15, "displacement_t": 7e4,
                  "breadth_m": 100.0, "depth_m": 100.0, "elements": 2}):  # ~ a steel block
        modes = compute_modes(hull_from_scenario(parse_scenario({"hull": hull,
                                                                 "based_on": "tanker"})))
        assert np.all(np.isfinite(modes.omega)) and modes.omega[2] > 0
    assert main(["modes", "--json"]) == 0
    json.loads(capsys.readouterr().out)


# --------------------------------------------------------------------------- names
@pytest.mark.parametrize("name", [".", "..", "a/b", "a\\b", "a\nb", "a b", "x" * 101, "",
                                  "tank\u00e9r", "\x00"])
def test_bad_scenario_names(name):
    _refused({"name": name}, "name = ", "letters, digits")


@pytest.mark.parametrize("name", ["tanker", "my-ship_2.v1", ".hidden", "x" * 100, "..a", "a.."])
def test_good_scenario_names(name):
    assert parse_scenario({"name": name}).name == name


def test_bag_and_fault_names_follow_the_same_rule():
    _refused({"lift": {"bags": [{"name": "../x", "kind": "external", "node": 2}]}}, "lift.bags[0].name")
    _refused({"faults": [{"kind": "sling_break", "bag": "b\n" * 10**5, "time_s": 1}]}, "faults[0].bag")


def test_dot_names_cannot_reach_the_output_folder(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "keep.txt").write_text("mine")
    p = _write(tmp_path, "name: ..\n")
    _cli_one_line(capsys, ["run", str(p), "--quiet"], "name = '..'")
    assert (tmp_path / "keep.txt").read_text() == "mine"
    assert not (tmp_path / "flexlift-out").exists()


# --------------------------------------------------------------------------- the scenario reference
def _fmt(x) -> str:
    if x == 2**63 - 1:
        return "2⁶³−1"
    if isinstance(x, float) and x.is_integer() and abs(x) < 1e5:
        x = int(x)
    if isinstance(x, int) and abs(x) < 1e5:
        return str(x)
    return f"{x:g}".replace("e+0", "e").replace("e+", "e").replace("e-0", "e-")


def _allowed(field) -> str:
    """A field's range as the scenario reference writes it: [a, b], [a, b) or a..b (whole numbers)."""
    cs = _constraints(field)
    lo = [(c.ge, "[") for c in cs if isinstance(c, at.Ge)] + [(c.gt, "(") for c in cs if isinstance(c, at.Gt)]
    hi = [(c.le, "]") for c in cs if isinstance(c, at.Le)] + [(c.lt, ")") for c in cs if isinstance(c, at.Lt)]
    (low, lb), (high, hb) = max(lo), min(hi)
    if "float" not in str(field.annotation):
        return f"{_fmt(low)}..{_fmt(high)}"
    return f"{lb}{_fmt(low)}, {_fmt(high)}{hb}"


def _reference_rows() -> dict[str, str]:
    """{dotted key: the 'allowed' cell of its row} of the scenario reference's tables
    (docs/reference/scenario.md, generated from the schema by docs/_hooks/reference.py when
    the site is built; a list's items are ``key[].item``)."""
    import importlib.util
    import re
    from pathlib import Path

    hook = Path(__file__).resolve().parents[1] / "docs" / "_hooks" / "reference.py"
    spec = importlib.util.spec_from_file_location("docs_reference_hook", hook)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    out = {}
    for line in module.scenario_tables().splitlines():
        if not line.startswith("| `"):
            continue
        cells = [c.strip() for c in re.split(r"(?<!\\)\|", line.strip()[1:-1])]  # not at \|
        assert len(cells) == 4, line
        out[cells[0].strip("`")] = cells[2]
    return out


def test_the_scenario_reference_states_every_range():
    rows = _reference_rows()
    for label, (field, _) in SLOTS.items():
        key = re.sub(r"\[0\]$", "", label.replace("[0].", "[]."))
        assert key in rows, f"the scenario reference has no row for {key}"
        assert _allowed(field) in rows[key], \
            f"scenario reference: {key} allows {_allowed(field)}, not {rows[key]!r}"


# --------------------------------------------------------------------------- the CLI's last line
def _boom(exc):
    def command(args):
        raise exc

    return command


def test_an_input_error_with_a_newline_is_still_one_line(capsys, monkeypatch):
    import flexlift.cli.loads as loads

    monkeypatch.setattr(loads, "_main", _boom(InputError("lift.bags.x\ny", "a\u2028b", "ok\r")))
    line = _cli_one_line(capsys, ["loads"], "lift.bags.x\\ny")
    assert "\\u2028" in line and "\\r" in line


@pytest.mark.parametrize("exc, code, needle", [
    (MemoryError(), 1, "out of memory"),
    (RuntimeError("solver\nexploded"), 1, "internal error: RuntimeError: solver\\nexploded"),
])
def test_unexpected_errors_are_one_line_and_exit_1(capsys, monkeypatch, exc, code, needle):
    import flexlift.cli.loads as loads

    monkeypatch.setattr(loads, "_main", _boom(exc))
    assert main(["loads"]) == code
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and needle in err and "Traceback" not in err, err
    assert main(["-v", "loads"]) == code  # -v: the traceback as well, for a bug report
    assert "Traceback" in capsys.readouterr().err


def test_a_numerics_failure_without_results_is_one_line_and_exit_1(capsys, monkeypatch):
    import flexlift.cli.simulate as cs
    from flexlift.errors import SimulationError

    monkeypatch.setattr(cs, "_main", _boom(SimulationError("numerics failed at t = 3.0 s")))
    assert main(["simulate"]) == 1
    err = capsys.readouterr().err
    assert err == "flexlift simulate: numerics failed at t = 3.0 s\n"
