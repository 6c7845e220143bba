"""The structure (docs/theory/beam.md): hull and beam data, Hermite elements, assembly, free-free modes
(:mod:`.modes`, with the large-model eigensolver of :mod:`.eigen`) and the convergence study."""
