"""The documentation site's generated pages, and the MkDocs hook that adds them
(``mkdocs.yml``: ``hooks: [bench/report/docs_site.py]``; ``make docs`` builds the site).

Nothing in these pages is typed by hand:

- ``reference/methods.md``: every registered method from the registry itself (its summary,
  whether it is causal, how it takes time stamps, each parameter's default, admissible range,
  tuning range and meaning, each preset with its values and source, its reference), and the
  frequency response of each linear one (:func:`response_figure`);
- ``results/<folder>/index.md``: one page per folder of committed results (``make bench``'s
  and ``make studies``'s), holding each of its Markdown tables and its figures as written.

The hand-written pages (``docs/*.md``) describe; where they quote a table they include the
generated file (``--8<--``, pymdown's snippets), so that a regeneration updates them too.
"""

from __future__ import annotations

import io
import re
from pathlib import Path

import numpy as np

from diffbench import methods
from diffbench.bench.report import explorer

_ROLE = re.compile(r":(?:\w+:)+`~?([^`]+)`")


def _plain(text: str) -> str:
    """A docstring paragraph as Markdown: reST roles (``:func:`x` ``) as code, one line."""
    text = _ROLE.sub(lambda match: f"`{match.group(1).split('.')[-1]}`", text)
    return " ".join(text.replace("``", "`").split())


def summary(cls) -> str:
    """The first paragraph of a method class's docstring, as one line of Markdown."""
    doc = (cls.__doc__ or "").strip()
    return _plain(doc.split("\n\n")[0]) if doc else ""


def _cell(value) -> str:
    return str(value).replace("|", "\\|")


RESPONSE_STEP_S = 1e-3
"""The step the reference's frequency responses are drawn at (the paper signal's)."""


def response_setting(name: str):
    """The setting whose response the reference draws: the ``paper-signal`` preset where the
    method has one, else its defaults (adapted to :data:`RESPONSE_STEP_S`)."""
    cls = methods.method_class(name)
    if "paper-signal" in cls.presets:
        return methods.preset(name, "paper-signal"), "its paper-signal preset"
    return methods.get(name).at_step(RESPONSE_STEP_S), "its defaults"


def response_figure(name: str) -> bytes | None:
    r"""PNG of method ``name``'s gain :math:`|H_n(f)|` for ẋ and ẍ at
    :func:`response_setting`, step :data:`RESPONSE_STEP_S`, up to Nyquist, against the ideal
    :math:`(2\pi f)^n` (``Method.frequency_response``, away from the ends); ``None`` for a
    method that is not linear (no response)."""
    from matplotlib.figure import Figure

    cls = methods.method_class(name)
    if not cls.linear:
        return None
    method, label = response_setting(name)
    frequency = np.geomspace(0.1, 0.5 / RESPONSE_STEP_S, 400)
    figure = Figure(figsize=(8, 3), layout="constrained")
    for axes, order in zip(figure.subplots(1, 2), (1, 2), strict=True):
        try:
            gain = np.abs(method.frequency_response(frequency, RESPONSE_STEP_S, order))
        except (NotImplementedError, ValueError):
            return None
        axes.loglog(frequency, gain, label=f"{name} ({label})")
        axes.loglog(frequency, (2 * np.pi * frequency) ** order, "k--", lw=0.8, label="ideal")
        axes.set_xlabel("frequency (Hz)")
        axes.set_ylabel(f"|H| of {'ẋ' if order == 1 else 'ẍ'}")
        axes.set_ylim(1e-3 * (2 * np.pi * 0.1) ** order, 10 * (np.pi / RESPONSE_STEP_S) ** order)
    axes.legend(fontsize="small", loc="lower center")
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=80)
    return buffer.getvalue()


def method_section(name: str, response: bool = False) -> str:
    """The reference section of method ``name``: summary, kind, parameters, presets (and its
    frequency response's figure, ``response-<name>.png``, with ``response``)."""
    cls = methods.method_class(name)
    kind = "causal (online)" if cls.causal else "offline"
    lines = [
        f"## `{name}`",
        "",
        summary(cls),
        "",
        f"{kind}; time stamps: {cls.time_stamps}; package: {methods.package_of(name)}"
        + (f"; reference: {_plain(cls.reference)}" if getattr(cls, "reference", "") else ""),
        "",
    ]
    specs = methods.params_of(cls)
    if specs:
        lines += [
            "| parameter | default | admissible | tuned over | meaning |",
            "|---|---|---|---|---|",
        ]
        for spec in specs:
            if spec.choices is not None:
                tuned = "its choices" if not spec.untuned else f"not tuned: {spec.untuned}"
            elif spec.tune_low is not None:
                scale = ", log" if spec.log else ""
                tuned = f"[{spec.tune_low:g}, {spec.tune_high:g}]{scale}"
            else:
                tuned = f"not tuned{': ' + spec.untuned if spec.untuned else ''}"
            if spec.ends_only:
                tuned += " (whole record only)"
            row = (f"`{spec.name}`", spec.default, spec.describe_range(), tuned, spec.doc)
            lines.append("| " + " | ".join(_cell(value) for value in row) + " |")
        lines.append("")
    if cls.presets:
        lines += ["| preset | values | by | source |", "|---|---|---|---|"]
        for key, preset in sorted(cls.presets.items()):
            values = ", ".join(f"{k}={v}" for k, v in preset.values.items())
            row = (f"`{key}`", values, preset.by, preset.source)
            lines.append("| " + " | ".join(_cell(value) for value in row) + " |")
        lines.append("")
    if response:
        label = response_setting(name)[1]
        lines += [
            f"Gain of ẋ and ẍ at {label}, step {RESPONSE_STEP_S:g} s, away from the ends:",
            "",
            f"![frequency response of {name}](response-{name}.png)",
            "",
        ]
    return "\n".join(lines)


def methods_reference(responses=frozenset()) -> str:
    """The methods reference page: every registered method (offline, then causal), with
    the frequency response of those in ``responses``."""
    names = methods.available(causal=False) + methods.available(causal=True)
    head = [
        "# Methods reference",
        "",
        f"Generated from the registry ({len(names)} methods, peers' adapters included): "
        "`diffbench list` prints the same. The default is the class default; "
        "*admissible* is what the method accepts, *tuned over* what the tuners search "
        "(a parameter marked *whole record only* changes only the estimates near the ends, "
        "which only a loss on the whole record tunes).",
        "",
    ]
    return "\n".join(head + [method_section(name, name in responses) for name in names])


def results_folders(root: Path) -> list[Path]:
    """The folders under ``root`` (a checkout's ``results/``) holding a Markdown table, the
    stores left out."""
    return sorted(
        {path.parent for path in root.rglob("*.md") if "store" not in path.relative_to(root).parts}
    )


def results_page(folder: Path, root: Path) -> str:
    """The page of one results folder: each Markdown table (its title one level down) and
    each figure, as written by the benchmark (``folder`` under ``root``, the ``results/``
    folder)."""
    relative = folder.relative_to(root.parent).as_posix()
    parts = [
        f"# `{relative}/`",
        "",
        f"Generated from the files in `{relative}/`. The same tables to sort, filter and "
        "plot: [the explorer](explorer.html).",
        "",
    ]
    for table in sorted(folder.glob("*.md")):
        text = table.read_text(encoding="utf-8")
        parts.append(re.sub(r"^# ", "## ", text, count=1, flags=re.M).rstrip("\n"))
        parts.append("")
    for figure in sorted(folder.glob("*.png")):
        parts += [f"![{figure.stem}]({figure.name})", ""]
    return "\n".join(parts)


def results_index(root: Path) -> str:
    """The page listing every results page."""
    lines = ["# Results", "", "Every folder of committed results, as the benchmark wrote it:", ""]
    for folder in results_folders(root):
        relative = folder.relative_to(root.parent).as_posix()
        lines.append(f"- [`{relative}/`]({folder.relative_to(root).as_posix()}/index.md)")
    return "\n".join(lines) + "\n"


try:  # MkDocs is needed only to build the site, not to generate its pages
    from mkdocs.plugins import event_priority

    _first = event_priority(100)
except ImportError:  # pragma: no cover

    def _first(function):
        return function


API_SOURCE = "build/api-source"
"""Where :func:`on_config` lays out ``methods/``, ``signals/`` and ``bench/`` as the packages
``diffbench.methods``, ``diffbench.signals`` and ``diffbench.bench`` (symbolic links), for
mkdocstrings (``mkdocs.yml``: its python handler's ``paths``): griffe finds packages by their
folders and cannot follow setuptools' editable ``package-dir`` mapping."""


@_first
def on_config(config):
    """MkDocs hook: the layout griffe reads the API reference's docstrings from (before
    mkdocstrings' own on_config, which resolves its paths)."""
    root = Path(config.config_file_path).parent
    package = root / API_SOURCE / "diffbench"
    package.mkdir(parents=True, exist_ok=True)
    for name in ("methods", "signals", "bench"):
        link = package / name
        if not link.is_symlink():
            link.symlink_to(root / name, target_is_directory=True)
    return config


SPHINX_ROLE = re.compile(r":(?:func|class|meth|mod|data|attr|obj|math):<code>(~?)([^<]*)</code>")
"""A Sphinx role the numpydoc docstrings use (``:func:`~x.y```) as mkdocstrings renders it:
the role's name left as text before the code."""


def on_page_content(html, page, config, files):
    """MkDocs hook: the API reference's Sphinx roles (which mkdocstrings leaves as text
    before their code) shown as the code alone, a ``~`` target by its last name, as Sphinx
    shows them."""
    if not page.file.src_uri.startswith("reference/api"):
        return html

    def plain(match):
        tilde, target = match.groups()
        return f"<code>{target.rsplit('.', 1)[-1] if tilde else target}</code>"

    return SPHINX_ROLE.sub(plain, html)


def on_files(files, config):
    """MkDocs hook: add the generated pages and the results' figures to the site."""
    from mkdocs.structure.files import File

    results = Path(config.config_file_path).parent / "results"  # beside mkdocs.yml
    drawn = {}
    for name in methods.available(causal=None):
        figure = response_figure(name)
        if figure is not None:
            drawn[name] = figure
            files.append(File.generated(config, f"reference/response-{name}.png", content=figure))
    reference = methods_reference(frozenset(drawn))
    files.append(File.generated(config, "reference/methods.md", content=reference))
    files.append(File.generated(config, "results/index.md", content=results_index(results)))
    script = f"assets/{explorer.PLOTLY_JS}"
    files.append(File.generated(config, script, content=explorer.plotly_js()))
    for folder in results_folders(results):
        within = folder.relative_to(results).as_posix()
        page = results_page(folder, results)
        files.append(File.generated(config, f"results/{within}/index.md", content=page))
        # the page's URL is results/<within>/explorer.html: as deep as <within>, plus one
        up = "../" * (len(Path(within).parts) + 1)
        title = f"results/{within}/"
        interactive = explorer.explorer_page(folder, title, assets=f"{up}assets")
        files.append(File.generated(config, f"results/{within}/explorer.html", content=interactive))
        for figure in sorted(folder.glob("*.png")):
            uri = f"results/{within}/{figure.name}"
            files.append(File.generated(config, uri, abs_src_path=str(figure)))
    return files
