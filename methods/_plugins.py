"""Methods registered from outside diffbench: entry points and modules named at run time.

A plugin is a Python module whose import registers methods with
:func:`diffbench.methods.register`. It is found in two ways:

- an installed distribution declares it as an entry point of the group ``diffbench.methods``
  (in its ``pyproject.toml``: ``[project.entry-points."diffbench.methods"]
  my_methods = "my_package.methods"``); every such entry point is loaded the first time the
  registry is asked for its methods;
- a module named for one run: ``diffbench --plugin my_module ...`` on the command line, or
  ``DIFFBENCH_PLUGINS=my_module,other_module`` in the environment (or
  :func:`load_plugin` from Python).

An entry point that fails to load is reported as a warning and skipped, so one broken
distribution does not disable diffbench; a module named explicitly that cannot be found is an
error naming it.
"""

from __future__ import annotations

import functools
import importlib
import os
import threading
import warnings
from dataclasses import dataclass
from importlib import metadata

ENTRY_POINT_GROUP = "diffbench.methods"
ENV_VARIABLE = "DIFFBENCH_PLUGINS"


@dataclass(frozen=True)
class Plugin:
    """A loaded plugin module, how it was found, and the distribution that ships it."""

    module: str
    found_by: str  # "entry point", "--plugin" or the environment variable's name
    distribution: str | None = None
    version: str | None = None

    @property
    def label(self) -> str:
        shipped = f" ({self.distribution} {self.version})" if self.distribution else ""
        return f"{self.module}{shipped}"


_LOADED: dict[str, Plugin] = {}
_MISSING: dict[str, str] = {}
_LOCK = threading.RLock()
_STATE = {"automatic": False}


def loaded_plugins() -> list[Plugin]:
    """The plugins loaded so far, in load order."""
    return list(_LOADED.values())


def plugin_of_module(module: str) -> Plugin | None:
    """The loaded plugin whose module is ``module`` or contains it (a method class's
    ``__module__``), None for diffbench's own code."""
    for plugin in _LOADED.values():
        if f"{module}.".startswith(f"{plugin.module}."):
            return plugin
    return None


def note_missing(prefix: str, hint: str) -> None:
    """Record that the methods named ``prefix.*`` are absent because a package is not
    installed, and how to get it (a plugin calls this instead of registering them)."""
    _MISSING[prefix] = hint


def missing_peers() -> dict[str, str]:
    """``{prefix: how to install}`` of the plugins whose package is not installed."""
    load_automatic_plugins()
    return dict(_MISSING)


def missing_hint(name: str) -> str:
    """How to get method ``name`` if its plugin noted its package missing, else ``""``."""
    prefix = name.split(".")[0]
    if "." in name and prefix in _MISSING:
        return f"{prefix}'s methods are not installed: {_MISSING[prefix]}"
    return ""


def load_plugin(module: str, found_by: str = "--plugin") -> Plugin:
    """Import ``module`` (registering its methods) unless it is loaded already.

    Raises ``ValueError`` naming the module and what went wrong if it cannot be found or its
    import fails (an exception, or ``sys.exit`` called while importing): the plugin is the
    user's choice, so its failure is the user's to fix, in one line, not diffbench's bug.
    """
    name = module.strip()
    if not name or not all(part.isidentifier() for part in name.split(".")):
        raise ValueError(f"plugin module {module!r} is not a dotted Python module name")
    with _LOCK:
        if name in _LOADED:
            return _LOADED[name]
        try:
            importlib.import_module(name)
        except ModuleNotFoundError as error:
            missing = error.name or ""
            if name == missing or name.startswith(missing + "."):
                raise ValueError(
                    f"plugin module {name!r} cannot be imported ({error}); install the package "
                    f"that provides it or add its folder to PYTHONPATH"
                ) from None
            raise ValueError(_import_failure(name, error)) from None
        except (Exception, SystemExit) as error:  # the plugin's own code failed on import
            raise ValueError(_import_failure(name, error)) from None
        plugin = Plugin(name, found_by, *_distribution_of(name))
        _LOADED[name] = plugin
        return plugin


def _import_failure(name: str, error: BaseException) -> str:
    """One line: which plugin module failed to import, and how."""
    if isinstance(error, SystemExit):
        how = f"it called sys.exit({error.code!r}) while being imported"
    else:
        detail = str(error).splitlines()[0] if str(error) else ""
        how = f"{type(error).__name__}: {detail}" if detail else type(error).__name__
    shipped = _distribution_of(name)[0]
    where = f" (from {shipped})" if shipped else ""
    return f"plugin module {name!r}{where} failed to import: {how}"


def load_automatic_plugins() -> None:
    """Load, once per process, every entry point of the group ``diffbench.methods`` and every
    module named in ``$DIFFBENCH_PLUGINS`` (comma-separated)."""
    with _LOCK:
        if _STATE["automatic"]:
            return
        _STATE["automatic"] = True  # set first: plugins call register(), which may ask again
        for entry_point in sorted(
            metadata.entry_points(group=ENTRY_POINT_GROUP), key=lambda e: e.name
        ):
            try:
                loaded = entry_point.load()
            except (Exception, SystemExit) as error:  # sys.exit on import must not end us
                shipped = entry_point.dist.name if entry_point.dist else "an unknown package"
                warnings.warn(
                    f"diffbench plugin {entry_point.name!r} ({entry_point.value}, from "
                    f"{shipped}) failed to load and is skipped: {type(error).__name__}: "
                    f"{error}",
                    RuntimeWarning,
                    stacklevel=2,
                )
                continue
            module = getattr(loaded, "__name__", entry_point.module)
            if module not in _LOADED:
                dist = entry_point.dist
                _LOADED[module] = Plugin(
                    module,
                    "entry point",
                    dist.name if dist else None,
                    dist.version if dist else None,
                )
        for name in os.environ.get(ENV_VARIABLE, "").split(","):
            if name.strip():
                try:
                    load_plugin(name, found_by=ENV_VARIABLE)
                except ValueError as error:
                    raise ValueError(f"${ENV_VARIABLE}: {error}") from None


@functools.cache
def distributions_of_modules() -> dict[str, list[str]]:
    """``importlib.metadata.packages_distributions()`` (top-level module -> distributions),
    read once per process: it reads every installed distribution's file list (about a second
    each time)."""
    return metadata.packages_distributions()


def _distribution_of(module: str) -> tuple[str | None, str | None]:
    top = module.split(".")[0]
    names = distributions_of_modules().get(top, [])
    if not names:
        return None, None
    return names[0], metadata.version(names[0])
