"""Plumbing every layer may use: files written atomically, files read within bounds, the
output lock. The bottom floor of the package (like :mod:`flexlift._jit` for compiling): it
imports nothing of flexlift but :mod:`flexlift.errors`, and every layer may import it.

- :mod:`flexlift.plumbing.atomic`: a reader never sees a half-written file.
- :mod:`flexlift.plumbing.reading`: every file flexlift reads (scenario, sweep SPEC, base
  scenario, controller ``.fis``) is a regular UTF-8 file of at most 1 MB, read without
  blocking; anything else is one line naming the file.
- :mod:`flexlift.plumbing.source`: the digest of flexlift's own code, for a cache of results
  to key on (a change to the code answers nothing from results the old code gave).
"""
