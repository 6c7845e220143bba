"""Hostile scenario files and values: one line naming the problem, exit 2, never a traceback
or a hang (issue 10). Most cases here were a traceback, a hang or a silent acceptance before;
the others guard what must keep working (a symlink to a file, a UTF-8 byte-order mark, YAML
merge keys, names such as ``.hidden``)."""

import os
import sys
import time

import pytest

from flexlift.cli import main
from flexlift.errors import InputError
from flexlift.scenario import load_scenario, parse_scenario

#: the documented limits of a scenario file (README, Scenario format)
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
    again = load_scenario(_write(tmp_path, "name: tanker\n"))
    assert again.model_dump(exclude={"description"}) == tanker.model_dump(exclude={"description"})


# --------------------------------------------------------------------------- YAML structure
def test_deep_flow_nesting_is_one_line(tmp_path, capsys):
    p = _write(tmp_path, "hull: " + "[" * 3000 + "]" * 3000 + "\n")  # a RecursionError before
    _refused(p, f"nesting deeper than {MAX_DEPTH} levels", "line 1")
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
    s = load_scenario(_write(tmp_path, "hull:\n  bending_stiffness_Nm2: 2e12\n  breadth_m: 1E1\n"
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
    assert tanker.to_yaml() == yaml.safe_dump(tanker.model_dump(mode="json"), sort_keys=False)
