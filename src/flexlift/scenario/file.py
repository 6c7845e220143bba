"""Reading a scenario file without trusting it.

A scenario file must be a regular file of at most :data:`MAX_BYTES`, in UTF-8, holding one
YAML document: a mapping whose keys are names, each given once, nested at most
:data:`MAX_DEPTH` levels and expanding (through YAML aliases) to at most :data:`MAX_VALUES`
values. Anything else is refused with one :class:`~flexlift.errors.InputError` line that
names the file, what is wrong (with its line and column) and what is allowed, before any of
it is handed to the schema: a hostile file can neither hang the loader (a FIFO, ``/dev/zero``,
a 50 MB file, an alias bomb) nor make it print a traceback (binary data, deep nesting).

YAML 1.2 numbers such as ``1e12`` are numbers here (PyYAML's YAML 1.1 rules read them as
text), so that a schema with strict numbers accepts what engineers write.
"""

from __future__ import annotations

import json
import re
from functools import lru_cache
from pathlib import Path

import yaml
from yaml.nodes import MappingNode, ScalarNode, SequenceNode

from flexlift.errors import InputError, clean
from flexlift.plumbing import reading
from flexlift.plumbing.reading import SCENARIO

#: largest scenario file [bytes] (every file flexlift reads has this limit): a 20,000-element
#: hull with per-element properties is ~0.5 MB
MAX_BYTES = reading.MAX_BYTES
#: deepest nesting of lists and mappings (a scenario needs 5: lift.bags[i].span_m)
MAX_DEPTH = 32
#: most values (scalars, lists, mappings) after expanding aliases: as many as a file at the
#: size limit can hold written out
MAX_VALUES = 1_000_000
#: longest integer literal [characters] (Python refuses to convert more than 4300 digits)
MAX_INT_CHARS = 100

_STR = "tag:yaml.org,2002:str"
_MERGE = "tag:yaml.org,2002:merge"
_Base = getattr(yaml, "CSafeLoader", yaml.SafeLoader)  # libyaml's parser when available


class _Loader(_Base):  # type: ignore[misc, valid-type]
    """PyYAML's safe loader with YAML 1.2 floats (``1e12``) and bounded integer literals."""

    def construct_yaml_int(self, node):
        text = str(node.value)
        if len(text) > MAX_INT_CHARS:
            raise yaml.constructor.ConstructorError(
                None, None, f"an integer of {len(text)} characters is far beyond any allowed "
                f"value (at most {MAX_INT_CHARS})", node.start_mark)
        return super().construct_yaml_int(node)


class _Dumper(yaml.SafeDumper):
    """PyYAML's safe dumper that quotes the text :class:`_Loader` would read as a number."""


#: the same dumper on libyaml's emitter when PyYAML has it (the same text, about 4x faster: a
#: sweep's case pays a scenario checksum, the SHA-256 of this text)
_FastDumper = (type("_FastDumper", (yaml.CSafeDumper,), {}) if getattr(yaml, "__with_libyaml__",
                                                                     False) else _Dumper)

_FLOAT_1_2 = re.compile(r"^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9][0-9_]*)[eE][-+]?[0-9]+$")
for _cls in {_Loader, _Dumper, _FastDumper}:
    _cls.add_implicit_resolver("tag:yaml.org,2002:float", _FLOAT_1_2, list("-+0123456789."))
_Loader.add_constructor("tag:yaml.org,2002:int", _Loader.construct_yaml_int)


def dump_yaml(data) -> str:
    """``data`` as YAML that :func:`load_yaml` reads back as the same data."""
    return yaml.dump(data, Dumper=_FastDumper, sort_keys=False)


#: entries' YAML kept per process by :func:`dump_sections` (a sweep's cases differ from their
#: base in a few keys; the checksum re-dumped every section, about 2 ms of a case, and then the
#: sections a case changes, ~1.2 ms of the tanker's: its lift section holds the bags)
SECTIONS_KEPT = 256
_SECTIONS: dict[str, str] = {}
#: PyYAML's line width (its emitter's ``best_width``) and block indent
_WIDTH, _INDENT = 80, 2
_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


def dump_sections(data: dict) -> str:
    """:func:`dump_yaml` of a JSON-ready mapping (a scenario's ``model_dump(mode="json")``),
    the same text, built from entries dumped on their own and kept by their JSON
    (:func:`_entry`). Where the text could differ, the whole is dumped: an empty mapping,
    values that share an object (YAML would write an anchor and an alias across entries), a
    value not of JSON's types (a tuple's JSON is a list's)."""
    if not data or not isinstance(data, dict) or not _plain(data):
        return dump_yaml(data)
    try:
        return "".join(_entry(key, value, True) for key, value in data.items())
    except (TypeError, ValueError):  # not JSON-ready: no key to keep it by
        return dump_yaml(data)


def _entry(key, value, top: bool) -> str:
    """The YAML of the one-entry mapping ``{key: value}`` (:func:`dump_yaml`'s text), kept by
    its JSON. A block mapping is its entries' lines one after another, each written alone the
    same way; one level down (``top``: a section's own keys) each line of an entry written
    alone is the same line indented by two spaces, so a section that is a non-empty mapping
    is put together from its keys' texts (a case that changes one key of the lift dumps that
    key, not the bags beside it). Only where that holds for certain: a plain key, and every
    line of every key's text within the line width less the indent (PyYAML breaks a long
    scalar at a width counted from the margin) with no blank line (a multi-line scalar's
    breaks); otherwise the section is dumped whole."""
    ident = json.dumps([key, value])
    text = _SECTIONS.pop(ident, None)
    if text is not None:  # kept, and now the most recently used
        _SECTIONS[ident] = text
        return text
    if (top and isinstance(value, dict) and value and isinstance(key, str) and _NAME.match(key)
            and all(isinstance(k, str) for k in value)):
        lines = [part[:-1].split("\n") for part in (_entry(k, v, False)
                                                      for k, v in value.items())]
        if (all(line and len(line) <= _WIDTH - _INDENT for part in lines for line in part)
                and _as_itself(key)):
            text = f"{key}:\n" + "".join(" " * _INDENT + line + "\n"
                                          for part in lines for line in part)
    if text is None:
        text = dump_yaml({key: value})
    _SECTIONS[ident] = text
    while len(_SECTIONS) > SECTIONS_KEPT:
        _SECTIONS.pop(next(iter(_SECTIONS)))
    return text


@lru_cache(maxsize=64)
def _as_itself(key: str) -> bool:
    """Whether YAML writes the mapping key ``key`` as it is (not quoted: ``yes``, ``null``)."""
    return dump_yaml({key: 0}) == f"{key}: 0\n"


def _plain(data) -> bool:
    """Whether ``data`` holds only JSON's types (dict, list, str, int, float, bool, None: two
    values with the same JSON then have the same YAML) and no list or mapping twice."""
    seen: set[int] = set()
    todo = [data]
    while todo:
        obj = todo.pop()
        if isinstance(obj, dict | list):
            if id(obj) in seen or (isinstance(obj, dict)
                                   and not all(isinstance(k, str) for k in obj)):
                return False
            seen.add(id(obj))
            todo.extend(obj.values() if isinstance(obj, dict) else obj)
        elif not (obj is None or isinstance(obj, str | int | float)):  # bool is an int
            return False
    return True


# --------------------------------------------------------------------------- the file
def _fail(source: str, what: str) -> InputError:
    return InputError.from_line(f"{source}: {what}")


def read_bytes(path: Path, source: str, builtins: str) -> bytes:
    """The bytes of the regular scenario file ``path`` (at most :data:`MAX_BYTES`, read by
    :func:`flexlift.plumbing.reading.read_bytes`); ``source`` names it in messages,
    ``builtins`` lists the built-in names for the "no such file" one."""
    kind = SCENARIO.with_missing(f"give a YAML path or a built-in name ({builtins})")
    return reading.read_bytes(path, source, kind)


def decode(data: bytes, source: str) -> str:
    """The text of a UTF-8 scenario file (a UTF-8 byte-order mark is allowed and dropped)."""
    return reading.decode(data, source, SCENARIO)


# --------------------------------------------------------------------------- the YAML
def _at(mark) -> str:
    return f"line {mark.line + 1}, column {mark.column + 1}" if mark is not None else "?"


class _Frame:
    """An open list or mapping while composing: its node, where it sits and what it holds."""

    __slots__ = ("node", "label", "anchor", "key", "keys", "size", "depth")

    def __init__(self, node, label: str, anchor: str | None):
        self.node, self.label, self.anchor = node, label, anchor
        self.key = None  # a mapping's key node waiting for its value
        self.keys: dict[str, int] = {}  # key -> line of its first occurrence
        self.size = 1  # values inside, this one included, aliases expanded
        self.depth = 1  # levels of nesting inside, this one included, aliases expanded


class _Composer:
    """PyYAML's node graph built from the parser's events without recursion (PyYAML's own
    composer recurses, so deep nesting ends in a RecursionError), checking the limits of the
    module docstring as it goes."""

    def __init__(self, loader, source: str):
        self.loader, self.source = loader, source
        self.stack: list[_Frame] = []
        self.anchors: dict[str, tuple] = {}  # name -> (node, size, depth) of a complete anchor
        self.open: set[str] = set()  # anchors whose content is still being read
        self.total = 0
        self.root = None
        self.documents = 0

    def fail(self, what: str, mark, hint: str = "") -> InputError:
        """``what`` went wrong at ``mark``; ``hint`` (beginning with "; " or " (") follows."""
        return _fail(self.source, f"{what} at {_at(mark)}{hint}")

    def path(self, last: str | None = None) -> str:
        parts = [f.label for f in self.stack[1:]] + ([last] if last is not None else [])
        return "".join(p if p.startswith("[") else "." + p for p in parts).lstrip(".")

    def compose(self, events):
        for ev in events:
            handler = getattr(self, "_" + type(ev).__name__, None)
            if handler is not None:
                handler(ev)
        return self.root

    # ------------------------------------------------------------------ events
    def _DocumentStartEvent(self, ev):
        self.documents += 1
        if self.documents > 1:
            raise self.fail("a second YAML document ('---')", ev.start_mark,
                            "; a scenario file holds one document")

    def _ScalarEvent(self, ev):
        tag = ev.tag
        if tag is None or tag == "!":
            tag = self.loader.resolve(ScalarNode, ev.value, ev.implicit)
        node = ScalarNode(tag, ev.value, ev.start_mark, ev.end_mark, style=ev.style)
        self._new_anchor(ev)
        self._add(node, 1, 0, ev)
        if ev.anchor is not None:
            self._close_anchor(ev.anchor, node, 1, 0)

    def _start(self, ev, cls):
        if len(self.stack) >= MAX_DEPTH:
            raise self.fail(f"nesting deeper than {MAX_DEPTH} levels", ev.start_mark,
                            "; a scenario needs at most 5")
        tag = ev.tag
        if tag is None or tag == "!":
            tag = self.loader.resolve(cls, None, ev.implicit)
        node = cls(tag, [], ev.start_mark, None, flow_style=ev.flow_style)
        self._new_anchor(ev)
        self.stack.append(_Frame(node, self._label(), ev.anchor))

    def _SequenceStartEvent(self, ev):
        self._start(ev, SequenceNode)

    def _MappingStartEvent(self, ev):
        self._start(ev, MappingNode)

    def _end(self, ev):
        frame = self.stack.pop()
        frame.node.end_mark = ev.end_mark
        self._add(frame.node, frame.size, frame.depth, ev)
        if frame.anchor is not None:
            self._close_anchor(frame.anchor, frame.node, frame.size, frame.depth)

    _SequenceEndEvent = _end
    _MappingEndEvent = _end

    def _AliasEvent(self, ev):
        name = clean(ev.anchor, 40)
        if ev.anchor in self.open:
            raise self.fail(f"alias *{name} used inside its own anchor (a recursive structure)",
                            ev.start_mark)
        if ev.anchor not in self.anchors:
            raise self.fail(f"alias *{name} with no anchor &{name} before it", ev.start_mark)
        node, size, depth = self.anchors[ev.anchor]
        if len(self.stack) + depth > MAX_DEPTH:
            raise self.fail(f"alias *{name} nests deeper than {MAX_DEPTH} levels", ev.start_mark)
        self._add(node, size, depth, ev, alias=name)

    # ------------------------------------------------------------------ helpers
    def _new_anchor(self, ev):
        if ev.anchor is not None:
            if ev.anchor in self.anchors or ev.anchor in self.open:
                raise self.fail(f"anchor &{clean(ev.anchor, 40)} defined twice", ev.start_mark)
            self.open.add(ev.anchor)

    def _close_anchor(self, name, node, size, depth):
        self.open.discard(name)
        self.anchors[name] = (node, size, depth)

    def _label(self) -> str:
        if not self.stack:
            return ""
        top = self.stack[-1]
        if isinstance(top.node, SequenceNode):
            return f"[{len(top.node.value)}]"
        return "?" if top.key is None else str(top.key.value)  # "?": a list or mapping as a key

    def _add(self, node, size: int, depth: int, ev, alias: str | None = None):
        self.total += size
        if self.total > MAX_VALUES:
            raise self.fail(f"more than {MAX_VALUES:,} values once the aliases are expanded "
                            f"(reached with {'alias *' + alias if alias else 'this value'})",
                            ev.start_mark, "; write the values out, or use fewer aliases")
        if not self.stack:
            self.root = node
            return
        top = self.stack[-1]
        top.size += size
        top.depth = max(top.depth, depth + 1)
        if isinstance(top.node, SequenceNode):
            top.node.value.append(node)
        elif top.key is None:
            self._key(top, node)
        else:
            top.node.value.append((top.key, node))
            top.key = None

    def _key(self, top: _Frame, node):
        where = self.path() or "the top level"
        if node.tag == _MERGE:  # "<<: *base" merges a mapping, whose keys may be overridden
            top.key = node
            return
        if not isinstance(node, ScalarNode) or node.tag != _STR:
            shown = (clean(node.value, 40) if isinstance(node, ScalarNode)
                     else "a list" if isinstance(node, SequenceNode) else "a mapping")
            raise self.fail(f"key {shown} in {clean(where)} is not a name", node.start_mark,
                            "; keys are names such as length_m")
        first = top.keys.get(node.value)
        if first is not None:
            raise self.fail(f"duplicate key {clean(self.path(node.value))}", node.start_mark,
                            f" (first given at line {first}); give each key once")
        top.keys[node.value] = node.start_mark.line + 1
        top.key = node


def load_yaml(text: str, source: str):
    """The Python data of one YAML document (``None`` for an empty one), or an InputError."""
    loader = _Loader("")
    try:
        node = _Composer(loader, source).compose(yaml.parse(text, Loader=_Loader))
        return None if node is None else loader.construct_document(node)
    except yaml.reader.ReaderError as exc:
        ch = exc.character if isinstance(exc.character, int) else ord(exc.character)
        i = max(text.find(chr(ch)), 0)
        line = text.count("\n", 0, i) + 1
        col = i - (text.rfind("\n", 0, i) + 1) + 1
        raise _fail(source, f"character U+{ch:04X} at line {line}, column {col} is not allowed "
                    "in YAML (a control character); remove it") from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        problem = str(getattr(exc, "problem", None) or "not valid YAML")
        if "nesting depth" in problem:  # libyaml's own limit (1000 levels of [ or {)
            raise _fail(source, f"nesting deeper than {MAX_DEPTH} levels{where}; a scenario "
                        "needs at most 5") from None
        raise _fail(source, f"malformed YAML{where}: {clean(str(problem), 120)}") from None
    finally:
        loader.dispose()
