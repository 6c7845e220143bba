"""The structure (SPEC §2): hull and beam data, Hermite elements, assembly, free-free modes
(:mod:`.modes`, with the large-model eigensolver of :mod:`.eigen`) and the convergence study."""
