"""Exceptions and warnings of the stiffness package."""


class StiffnessError(ValueError):
    """Bad input to a stiffness computation (names the field and what was expected)."""


class SingularPoseError(StiffnessError):
    """The pose (or the stiffness matrix) is singular: compliance, leg forces and
    deflections are undefined there.  The message gives cond(P) (or cond(K))."""


class SingularPoseWarning(UserWarning):
    """The leg matrix P is near singular: stiffness figures there are unreliable, and
    leg forces and deflections are amplified by up to cond(P)."""
