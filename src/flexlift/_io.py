"""Moved to :mod:`flexlift.output.files` (kept while :mod:`flexlift.fis` still imports it)."""

from flexlift.output.files import write_json, write_text

__all__ = ["write_json", "write_text"]
