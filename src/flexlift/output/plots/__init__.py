"""Matplotlib figures: each function takes computed data and returns a Figure (never shows it).

One module per stage (``modes``, ``loads``, ``reduce``, ``fuzzy``, ``ascent``); the common
style and the saver live in ``_style``.
"""
