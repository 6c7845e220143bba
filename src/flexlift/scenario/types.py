"""What a number, a name and a range are in a scenario file (used by :mod:`flexlift.scenario`).

Numbers are strict: an integer may be given for a real number, but never a boolean or text
(pydantic's lax mode would read ``true`` as 1 and ``"78"`` as 78), and never NaN or infinity.
Every number of the schema is given a closed range with :func:`real` or :func:`whole`; the
module constants are the limits several keys share, with the reason for each.
"""

from __future__ import annotations

import re
from typing import Annotated

from pydantic import AfterValidator, BeforeValidator, Field, Strict
from pydantic_core import PydanticCustomError


def _number(v):
    """Refuse what pydantic's lax mode would turn into a number: booleans and text."""
    if isinstance(v, bool):
        raise PydanticCustomError("number_type", "a number is needed here, not true/false")
    if isinstance(v, str | bytes):
        raise PydanticCustomError(
            "number_type", "a number is needed here, not text (write it without quotes)")
    return v


Real = Annotated[float, BeforeValidator(_number), Field(allow_inf_nan=False)]
Whole = Annotated[int, BeforeValidator(_number)]
Text = Annotated[str, Strict()]
Flag = Annotated[bool, Strict()]


def real(lo: float, hi: float):
    """A finite real number in [lo, hi]. Positive quantities get a small positive lower bound
    (not merely > 0: a denormal 5e-324 t would pass that, and the modes would be NaN)."""
    return Annotated[Real, Field(ge=lo, le=hi)]


def whole(lo: int, hi: int):
    """An integer in [lo, hi] (a real number with no fraction is accepted)."""
    return Annotated[Whole, Field(ge=lo, le=hi)]


#: names of scenarios, bags and faults' bags: they name folders, files and table columns
NAME_MAX = 100
_NAME = re.compile(r"[A-Za-z0-9_.\-]+")


def _name(v: str) -> str:
    if len(v) > NAME_MAX or not _NAME.fullmatch(v) or v in (".", ".."):
        raise PydanticCustomError(
            "name", f"a name is 1..{NAME_MAX} letters, digits, '_', '-' or '.' (not '.' or '..' "
            "alone): it names folders and files")
    return v


Name = Annotated[Text, AfterValidator(_name)]

#: longest hull in metres, and the most elements (the sparse modal solver handles 20,000 in
#: a few seconds; the SPEC's pipelines need thousands)
MAX_LENGTH_M = 20_000.0
MAX_ELEMENTS = 20_000
#: heaviest structure [t]: the largest ships displace ~660,000 t
MAX_MASS_T = 1.0e6
#: largest lift of one bag [t] (the tanker's modelled bags lift 517 t)
MAX_BAG_LIFT_T = 5_000.0
#: most bags or faults listed
MAX_ITEMS = 1_000
#: longest time of any kind [s] (about 11.6 days)
MAX_TIME_S = 1.0e6
#: the simulation's size limits: its time steps and stored rows
MAX_STEPS = 10_000_000
MAX_ROWS = 100_000
