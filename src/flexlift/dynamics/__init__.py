"""The modal state space of the bags (docs/theory/reduction.md#modal-state-space) and its reduction (del/mdc, sorted/unsorted)."""
