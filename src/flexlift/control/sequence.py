"""A staged lift (docs/theory/statics.md#staged): when each external bag starts, from ``control.sequence``.

Pipelines are peeled off the seabed from one end: once the suction has let go, the bags
begin their ascent in groups, one group every ``delay_s``. :func:`start_times` turns the
scenario's sequence into each bag's delay [s] after the hold lets go (0 for every bag without
a sequence); the controllers (:mod:`flexlift.control.controller`) hold a bag passive, at its
neutral volume, until then.
"""

from __future__ import annotations

import numpy as np

from flexlift.errors import InputError


def stage_groups(scenario, names, x, external) -> list[list[int]]:
    """The groups of a staged lift in order, as bag indices into ``names`` (one group of all
    external bags without a sequence). ``x`` [m] the bag points, ``external`` bool per bag.
    InputError (one line) for a sequence that names an unknown or internal bag, names one
    twice, or leaves an external bag out."""
    seq = scenario.control.sequence
    ext = [i for i in range(len(names)) if external[i]]
    if seq is None:
        return [ext]
    if seq.groups is None:
        order = sorted(ext, key=lambda i: (x[i], i), reverse=seq.from_end == "end")
        return [order[k:k + seq.group_size] for k in range(0, len(order), seq.group_size)]
    index = {n: i for i, n in enumerate(names)}
    seen: dict[str, str] = {}
    groups = []
    for g, group in enumerate(seq.groups):
        for k, name in enumerate(group):
            key = f"control.sequence.groups[{g}][{k}]"
            if name not in index:
                raise InputError(key, name, f"not a bag of this plan; its bags are "
                                 f"{_names(names)}")
            if not external[index[name]]:
                raise InputError(key, name, "an internal bag: it is full from the start and not "
                                 "filled by the controllers; list only external bags")
            if name in seen:
                raise InputError(key, name, f"already in {seen[name]}; name each bag once")
            seen[name] = f"group {g}"
        groups.append([index[n] for n in group])
    missing = [names[i] for i in ext if names[i] not in seen]
    if missing:
        raise InputError("control.sequence.groups", f"{len(seen)} of {len(ext)} external bags",
                         f"every external bag must start in some group; missing: "
                         f"{_names(missing)}")
    return groups


def start_times(scenario, names, x, external) -> np.ndarray:
    """Delay [s] of every bag's ascent after its hold lets go (nb,): group k of
    :func:`stage_groups` at k ``delay_s``; 0 for internal bags and without a sequence."""
    seq = scenario.control.sequence
    start = np.zeros(len(names))
    delay = seq.delay_s if seq is not None else 0.0
    for k, group in enumerate(stage_groups(scenario, names, x, external)):
        start[group] = k * delay
    return start


def _names(names, most: int = 8) -> str:
    names = list(names)
    text = ", ".join(names[:most])
    return text + (f" and {len(names) - most} more" if len(names) > most else "")
