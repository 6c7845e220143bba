"""Writing results: atomic files and output folders that replace only flexlift's own."""

from flexlift.output.folders import MARKER, OutputError, output_folder
from flexlift.plumbing.atomic import atomic_file, write_json, write_text

__all__ = ["MARKER", "OutputError", "atomic_file", "output_folder", "write_json", "write_text"]
