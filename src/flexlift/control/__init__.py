"""The ascent's controllers (docs/theory/control.md): reference, supervisor, SIFSMC fill, PID purge and
coordination, compiled and vectorised over the controlled bags."""
