"""How a mode is named wherever a user sees one (report, figures, tables, JSON, CLI).

The two rigid modes are named ``heave`` and ``pitch``; the flexible modes are numbered 1, 2, ...
from the first flexible mode, as the scenario keys count them (``lift.layout_flexible_mode``,
``simulation.retained_flexible_modes``). Internally a mode is a 0-based column of
:class:`~flexlift.structure.modes.Modes` (rigid first), or the 1-based ``mode_numbers`` of a
:class:`~flexlift.dynamics.statespace.ModalStateSpace`; these functions translate.
"""

from __future__ import annotations

RIGID_NAMES = ("heave", "pitch")


def mode_label(column: int, n_rigid: int = 2) -> str:
    """Short label of the mode in 0-based ``column``: "heave", "pitch", "1", "2", ..."""
    column = int(column)
    if column < n_rigid:
        return RIGID_NAMES[column] if n_rigid == len(RIGID_NAMES) else f"rigid {column + 1}"
    return str(column - n_rigid + 1)


def mode_title(column: int, n_rigid: int = 2) -> str:
    """The mode in a sentence: "heave", "pitch", "flexible mode 3", ..."""
    label = mode_label(column, n_rigid)
    return label if int(column) < n_rigid else f"flexible mode {label}"


def labels_of_numbers(numbers, n_rigid: int = 2) -> list[str]:
    """Labels of the 1-based global ``mode_numbers`` of a state-space model."""
    return [mode_label(int(n) - 1, n_rigid) for n in numbers]


def mode_list(labels) -> str:
    """Labels in a sentence or a table cell: "heave, pitch; flexible 1, 2, 5" (rigid names
    first as given, then the flexible numbers), "" for none."""
    labels = [str(s) for s in labels]
    rigid = [s for s in labels if not s.isdigit()]
    flex = [s for s in labels if s.isdigit()]
    parts = [", ".join(rigid)] if rigid else []
    if flex:
        parts.append("flexible " + ", ".join(flex))
    return "; ".join(parts)
