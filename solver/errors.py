"""Exceptions the command line turns into exit codes: bad input (2), numerical failure (3),
SIGTERM (143)."""


class InputError(Exception):
    """A user error: message names the key or file, the value and what is allowed."""


class Interrupted(RuntimeError):
    """SIGTERM arrived; the unit in flight was finished and finished units are kept."""


class NumericalFailure(RuntimeError):
    """A computation that failed numerically (a time integration that blew up), raised on every
    rank together; nothing of it is written."""
