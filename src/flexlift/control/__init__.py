"""The ascent's controllers (SPEC §7): reference, supervisor, SIFSMC fill, PID purge and
coordination, compiled and vectorised over the controlled bags."""
