"""The robustness census of issue 11 ("No silent wrong answers"): bad inputs that must raise
a clear project error naming the argument, and awkward-but-valid inputs that must give
the right answer.  ``python -m tests.robustness.census`` prints the table."""
