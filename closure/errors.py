"""Exceptions raised by the closure engine.

Every error that a user can cause by bad input is a ``ValueError`` subclass
(:class:`MechanismError`); numerical trouble that the input did not make
obvious (no assembly, a dead point) is a :class:`ClosureError`, which carries
the figures that show it.
"""
from __future__ import annotations


class MechanismError(ValueError):
    """Bad mechanism structure or bad input (names the field and what was expected)."""


class ClosureError(RuntimeError):
    """The loop-closure equations could not be solved to tolerance.

    Attributes
    ----------
    residual : numpy.ndarray
        Largest loop residual of each failing input (rad, or length / scale).
    condition : numpy.ndarray
        Condition number of the unknowns' Jacobian of each failing input.
    inputs : numpy.ndarray
        The failing input values.
    """

    def __init__(self, message, *, inputs=None, residual=None, condition=None):
        super().__init__(message)
        self.inputs = inputs
        self.residual = residual
        self.condition = condition
