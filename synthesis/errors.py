"""Exceptions of the synthesis package."""


class SynthesisError(ValueError):
    """Bad input or a degenerate synthesis problem (names the cause and the figure)."""
