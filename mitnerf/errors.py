"""One error type for bad input. Its message names the problem *and* the fix.

The command-line interface prints it as one line and exits with status 2.
"""


class MitnerfError(ValueError):
    """Bad input: the message says what is wrong and how to fix it."""
