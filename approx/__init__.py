"""approx — piecewise-linear approximation of acceleration analogs (seed 004)."""
