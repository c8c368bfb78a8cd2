"""Exceptions and warnings of the stiffness package."""


class StiffnessError(ValueError):
    """Bad input to a stiffness computation (names the field and what was expected)."""


class SingularPoseWarning(UserWarning):
    """The leg matrix P is near singular: stiffness figures there are unreliable."""
