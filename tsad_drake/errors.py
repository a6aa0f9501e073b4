"""The errors that mean bad input: the command line turns each into one line and exit status 2."""

from __future__ import annotations

#: exit status of a command given bad input
EXIT_BAD_INPUT = 2
#: exit status of a command stopped by SIGINT (Ctrl-C), as the shell reports it
EXIT_INTERRUPTED = 130


def first_line(err: Exception) -> str:
    """The first line of an exception's message (Drake's parse errors run to many lines), or
    its type's name when the message is empty: what a one-line refusal quotes."""
    text = str(err).strip()
    return text.splitlines()[0] if text else type(err).__name__


class UsageError(ValueError):
    """Bad command-line input or a bad file given on it (exit status 2)."""


class ScenarioError(UsageError):
    """A scenario that is malformed or physically impossible (exit status 2)."""


class WeightsError(UsageError):
    """A prehensile network weights file that is missing, unreadable or does not match the model."""


class InputFileError(UsageError):
    """A data file given as input (dataset shard, bench result, bench rows) that is unreadable or
    malformed."""


class RunFailure(RuntimeError):
    """A command that could not finish for a reason outside its input (a worker process killed):
    one line and exit status 1."""
