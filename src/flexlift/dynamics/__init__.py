"""The modal state space of the bags (SPEC §4) and its reduction (del/mdc, sorted/unsorted)."""
