"""The errors that mean bad input: the command line turns each into one line and exit status 2."""

from __future__ import annotations

#: exit status of a command given bad input
EXIT_BAD_INPUT = 2


class UsageError(ValueError):
    """Bad command-line input or a bad file given on it (exit status 2)."""


class ScenarioError(UsageError):
    """A scenario that is malformed or physically impossible (exit status 2)."""


class WeightsError(UsageError):
    """A prehensile network weights file that is missing, unreadable or does not match the model."""
