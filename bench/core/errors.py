"""What the API says to its caller besides results: bad input (:class:`BadInput`, a
``ValueError`` naming the argument and the fix) and remarks given as Python warnings
(:class:`DiffbenchWarning`, :class:`DiffbenchNote`); how a plugin's failure is named
(:func:`plugin_failure`)."""

from __future__ import annotations

from diffbench import methods
from diffbench.methods._plugins import plugin_of_module


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


def plugin_label(method: str) -> str | None:
    """``"plugin MODULE (dist NAME VERSION)"`` when ``method`` comes from a plugin outside
    diffbench's own distribution, else None (diffbench's own code)."""
    plugin = plugin_of_module(methods.method_class(method).__module__)
    if plugin is None or plugin.distribution == "diffbench":
        return None
    dist = f"{plugin.distribution} {plugin.version}" if plugin.distribution else "none"
    return f"plugin {plugin.module} (dist {dist})"


def plugin_failure(method: str, error: BaseException) -> str | None:
    """``"plugin MODULE (dist NAME VERSION): method M: Error: message"`` when ``method``
    comes from a plugin (:func:`plugin_label`), else None (diffbench's code: its bug)."""
    label = plugin_label(method)
    if label is None:
        return None
    text = str(error).strip().splitlines()
    detail = f"{type(error).__name__}: {text[0]}" if text else type(error).__name__
    return f"{label}: method {method}: {detail}"


def timeout_failure(method: str, seconds: float) -> str:
    """``"[plugin MODULE (dist ...): ]method M: a call timed out after S s (--timeout)"``: a
    call of ``method`` inside a tuning or a recommendation that outlived ``seconds``."""
    label = plugin_label(method)
    where = f"{label}: " if label else ""
    return f"{where}method {method}: a call timed out after {seconds:g} s (--timeout)"
