"""Stage 5, warning: safety-distance models and the warning logic (levels, hysteresis)."""
