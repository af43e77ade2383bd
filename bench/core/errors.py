"""What the API says to its caller besides results: bad input (:class:`BadInput`, a
``ValueError`` naming the argument and the fix) and remarks given as Python warnings
(:class:`DiffbenchWarning`, :class:`DiffbenchNote`)."""

from __future__ import annotations


class BadInput(ValueError):
    """Bad input to the API: the message names the argument and the fix.

    A message from a check deeper down names the argument the way the command line spells it
    (``--seeds`` for the API's ``seeds=``). The command line reports it in one line on stderr
    with exit code 2; any other exception is an internal error (its traceback, exit code 1).
    """


class DiffbenchWarning(UserWarning):
    """Something the user should know (a failed cell, a record not imported)."""

    label = "warning"


class DiffbenchNote(DiffbenchWarning):
    """A note (stored cells of other code revisions, a file no longer read)."""

    label = "note"


class MethodSkipped(DiffbenchWarning):
    """A method a criterion cannot tune, left out (the command line shows it as it is)."""

    label = None
