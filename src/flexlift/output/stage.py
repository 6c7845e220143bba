"""What a stage hands to ``flexlift run`` and the report: its JSON summary, figures, tables."""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass, field
from pathlib import Path


@dataclass(frozen=True)
class Figure:
    """A written figure: file path (PNG) and a one-sentence caption."""

    path: Path
    caption: str


@dataclass(frozen=True)
class Table:
    """A table for the report and CSV: a title, column names (with units), and rows.

    csv : the file name under ``tables/`` the stage writes it to ("" when none)
    in_report : False for a table too long for the page (the report names its CSV instead)
    """

    title: str
    columns: list[str]
    rows: list[list]
    note: str = ""
    csv: str = ""
    in_report: bool = True

    def to_csv(self) -> str:
        """The table as CSV text: a header of the column names, then the rows (None -> empty)."""
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(self.columns)
        w.writerows(["" if v is None else v for v in row] for row in self.rows)
        return buf.getvalue()


@dataclass(frozen=True)
class StageOutput:
    """One stage's result as the CLI and the report see it.

    summary : the JSON object the stage's ``--json`` prints
    figures, tables : for the report (figures already written under the output folder)
    warnings : one-line warnings with numbers and the fix (e.g. a lift shortfall)
    criteria : name -> passed (True/False) for checks shown with pass/fail marks
    """

    name: str
    summary: dict
    figures: list[Figure] = field(default_factory=list)
    tables: list[Table] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    criteria: dict[str, bool] = field(default_factory=dict)
