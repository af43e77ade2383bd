"""The architecture holds: bench's layers import only downwards, no import cycle hides in a
function body, no module of bench/ passes 600 lines, and ARCHITECTURE.md names only modules
that exist (issue 44)."""

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = {"methods": ROOT / "methods", "signals": ROOT / "signals", "bench": ROOT / "bench"}

LAYERS = ("core", "report", "studies", "tasks", "top")
"""bench's layers, lowest first: a module may import from its own layer and those below.
``top`` is what runs the tasks: the runner, the API and the CLI."""


def module_name(path: Path) -> str:
    """diffbench.<package>.<...> of a source file."""
    for package, folder in PACKAGES.items():
        if folder in path.parents:
            parts = path.relative_to(folder).with_suffix("").parts
            if parts[-1] == "__init__":
                parts = parts[:-1]
            return ".".join(("diffbench", package, *parts))
    raise ValueError(path)


def sources() -> dict[str, Path]:
    return {
        module_name(path): path
        for folder in PACKAGES.values()
        for path in sorted(folder.rglob("*.py"))
    }


def layer(module: str) -> str | None:
    """The layer of a diffbench.bench module (None outside bench)."""
    parts = module.split(".")
    if parts[:2] != ["diffbench", "bench"]:
        return None
    if len(parts) > 2 and parts[2] in LAYERS[:-1]:
        return parts[2]
    return "top"


def imports(path: Path, module: str) -> list[tuple[str, bool, int]]:
    """(imported diffbench module, at module level?, line) of every import in ``path``,
    ``from X import name`` counted as X.name when that is a module."""
    known = sources()
    tree = ast.parse(path.read_text())
    found = []
    top_level = {id(node) for node in tree.body}
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                package = module.split(".")
                if not path.name == "__init__.py":
                    package = package[:-1]
                base = ".".join(package[: len(package) - node.level + 1] + ([base] if base else []))
            targets = [
                f"{base}.{alias.name}" if f"{base}.{alias.name}" in known else base
                for alias in node.names
            ]
        else:
            continue
        for target in targets:
            if target.startswith("diffbench."):
                found.append((target, id(node) in top_level, node.lineno))
    return found


def test_the_modules_are_found():
    found = sources()
    assert "diffbench.bench.runner" in found and "diffbench.bench.tasks.base" in found
    assert "diffbench.methods" in found and len(found) > 60


def test_methods_and_signals_never_import_bench():
    bad = [
        f"{module} imports {target} (line {line})"
        for module, path in sources().items()
        if layer(module) is None
        for target, _, line in imports(path, module)
        if target.startswith("diffbench.bench")
    ]
    assert not bad, "\n".join(bad)


def test_bench_layers_import_only_downwards():
    bad = []
    for module, path in sources().items():
        own = layer(module)
        if own is None:
            continue
        for target, _, line in imports(path, module):
            theirs = layer(target)
            if theirs is not None and LAYERS.index(theirs) > LAYERS.index(own):
                bad.append(f"{module} ({own}) imports {target} ({theirs}), line {line}")
    assert not bad, "\n".join(bad)


def test_no_diffbench_import_is_hidden_in_a_function():
    """An import of diffbench inside a function is how a cycle hides: none in bench/."""
    bad = [
        f"{path.relative_to(ROOT)}:{line} imports {target} inside a function"
        for module, path in sources().items()
        if layer(module) is not None
        for target, top, line in imports(path, module)
        if not top
    ]
    assert not bad, "\n".join(bad)


def test_no_import_cycle():
    """The module-level import graph of diffbench has no cycle (depth-first search)."""
    known = sources()
    graph = {
        module: sorted(
            {
                target if target in known else target.rsplit(".", 1)[0]
                for target, top, _ in imports(path, module)
                if top
            }
            & set(known)
        )
        for module, path in known.items()
    }
    # a package's __init__ importing its own submodules is not a cycle back to it
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(module: str) -> None:
        state[module] = 1
        stack.append(module)
        for target in graph[module]:
            if target == module or module.startswith(target + "."):
                continue  # a submodule's import of its parent package runs its __init__ first
            if state.get(target) == 1:
                cycle = [*stack[stack.index(target) :], target]
                pytest.fail("import cycle: " + " -> ".join(cycle))
            if target not in state:
                visit(target)
        stack.pop()
        state[module] = 2

    for module in graph:
        if module not in state:
            visit(module)


LONGEST_MODULE = 600
"""The most lines a module of bench/ may have (issue 44)."""


NOT_YET_SPLIT: dict[str, str] = {}
"""Modules still over :data:`LONGEST_MODULE` lines, each with what will shorten it; a module
that gets short enough must leave this list (the test says so)."""


def test_no_module_of_bench_is_longer_than_600_lines():
    lines = {
        str(path.relative_to(ROOT)): len(path.read_text().splitlines())
        for path in (ROOT / "bench").rglob("*.py")
    }
    long = {path for path, count in lines.items() if count > LONGEST_MODULE}
    assert long <= set(NOT_YET_SPLIT), {path: lines[path] for path in long - set(NOT_YET_SPLIT)}
    assert set(NOT_YET_SPLIT) <= long, f"short enough now: {set(NOT_YET_SPLIT) - long}"


def test_the_source_root_holds_the_three_packages():
    from diffbench.bench.core.provenance import SOURCE_ROOT

    assert all((SOURCE_ROOT / name / "__init__.py").is_file() for name in PACKAGES)


def test_architecture_names_only_modules_that_exist():
    text = (ROOT / "ARCHITECTURE.md").read_text()
    named = set(re.findall(r"`((?:bench|methods|signals)/[\w/]+\.py)`", text))
    folders = set(re.findall(r"`((?:bench|methods|signals)/[\w/]*)/`", text))
    assert len(named) >= 15, named
    missing = sorted(p for p in named if not (ROOT / p).is_file())
    missing += sorted(f + "/" for f in folders if not (ROOT / f).is_dir())
    assert not missing, missing
    every_layer = {f"bench/{name}/" for name in LAYERS[:-1]}
    assert every_layer <= {f + "/" for f in folders}, every_layer
