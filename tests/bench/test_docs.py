"""The front door (issue 46, items 1 and 2): a README of at most 150 lines whose figures come
from generated files, its code run as a user would, and a documentation site that builds
strictly with its methods reference and results pages generated."""

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from diffbench import methods
from diffbench.bench.report import docs_site

ROOT = Path(__file__).resolve().parents[2]
README = (ROOT / "README.md").read_text(encoding="utf-8")
GENERATED = re.compile(r"<!-- generated: (\S+) -->\n(.*?)<!-- end generated -->\n", re.S)
PAGES = sorted((ROOT / "docs").rglob("*.md"))
"""The documentation's hand-written pages; the generated ones (the methods reference, the
results pages) are added by the hook (bench/report/docs_site.py) to the built site only."""
SNIPPET = re.compile(r"^[ \t]*-+8<-+[ \t]+\"([^\"]+)\"[ \t]*$", re.M)

ALLOWED_NUMBERS = {
    "3.10",  # the Python the quick start needs
    "2015",  # the seed paper's year
    "4/9/15",  # the paper signal's lines, Hz
    "2-joint",  # the robot
    "2R",
    "BSD-3",  # the licences
    "BSD-3-Clause",
}
"""Digit-bearing words the README's hand-written prose may hold: facts of the project, not
results (every result is in a generated block)."""

DOCS_ALLOWED_NUMBERS = ALLOWED_NUMBERS | {
    "5/2",  # the Matérn processes' smoothness: their names
    "7/2",
    "1966",  # the years of the papers the pages cite: Gentleman & Sande; Burrus; Kim et al.
    "1972",  # and Mboup, Join & Fliess; Khalil & Praly; Seeber
    "2009",
    "2014",
    "2024",
}
"""Digit-bearing words the documentation's hand-written pages may hold beyond the README's:
facts again; every result is included from a generated file (``--8<--``) or linked."""


def _blocks(text: str, language: str) -> list[str]:
    return re.findall(rf"```{language}\n(.*?)```\n", text, re.S)


def test_the_readme_is_at_most_150_lines():
    assert len(README.splitlines()) <= 150


def test_the_readmes_generated_blocks_are_the_generated_files_tables():
    blocks = GENERATED.findall(README)
    assert blocks, "the README quotes no generated file"
    for source, block in blocks:
        text = (ROOT / source).read_text(encoding="utf-8")
        table = "".join(line for line in text.splitlines(keepends=True) if line.startswith("|"))
        assert block == table, f"README's copy of {source} is stale: copy its table again"


def _numbers_in_prose(text: str) -> set[str]:
    """The digit-bearing words of a Markdown text's hand-written prose: outside generated
    blocks, fenced and inline code (commands and code, not results), snippet lines (they
    include generated files), HTML comments, link targets, image paths and URLs, and the
    markers of ordered lists."""
    prose = GENERATED.sub("", text)
    prose = re.sub(r"^[ \t]*(`{3,}|~{3,}).*?^[ \t]*\1[ \t]*$", "", prose, flags=re.S | re.M)
    prose = SNIPPET.sub("", prose)
    prose = re.sub(r"<!--.*?-->", "", prose, flags=re.S)
    prose = re.sub(r"`[^`\n]*`", "", prose)
    prose = re.sub(r"^[ \t]*\d+\.[ \t]", "", prose, flags=re.M)  # an ordered list's markers
    prose = re.sub(r"\]\([^()\s]*(?:\s+\"[^\"]*\")?\)", "]", prose)  # [text](target "title")
    prose = re.sub(r"^[ \t]*\[[^\]]+\]:[ \t]*\S+.*$", "", prose, flags=re.M)  # [ref]: target
    prose = re.sub(r"<?https?://[^\s>)]+>?", "", prose)
    return {w.strip(".,;:()*[]!?\"'") for w in prose.split() if re.search(r"\d", w)}


def test_no_result_is_typed_into_the_readmes_prose():
    words = _numbers_in_prose(README)
    assert words <= ALLOWED_NUMBERS, sorted(words - ALLOWED_NUMBERS)


def test_the_docs_have_hand_written_pages_and_no_generated_ones():
    names = {page.relative_to(ROOT / "docs").as_posix() for page in PAGES}
    assert {"index.md", "findings.md", "methods.md"} <= names
    # the hook adds these to the site: a copy under docs/ would be typed, and go stale
    assert not any(name.startswith(("reference/methods", "results/")) for name in names)


@pytest.mark.parametrize("page", PAGES, ids=lambda page: page.relative_to(ROOT).as_posix())
def test_no_result_is_typed_into_a_docs_page(page):
    """Issue 46: a page shows a result by including the generated file (``--8<--``), its
    figure, or a link to its results page, never by typing a number into its prose."""
    words = _numbers_in_prose(page.read_text(encoding="utf-8"))
    assert words <= DOCS_ALLOWED_NUMBERS, sorted(words - DOCS_ALLOWED_NUMBERS)


def test_the_checker_finds_a_typed_result():
    page = "The spectral method leads (RMSE 2.00 on the interior), see `rmse.md`.\n"
    assert _numbers_in_prose(page) == {"2.00"}
    exempt = (
        '```sh\nmake bench SEEDS=5\n```\n--8<-- "results/paper-signal/rmse.md:3:"\n'
        "<!-- 2.00 -->\n![errors](results/paper-signal/errors.png) at `dt=0.001`, "
        "[issue](https://github.com/x/y/issues/46)\n"
    )
    assert _numbers_in_prose(exempt) == set()


def test_the_docs_include_only_generated_files():
    """A page's snippets are the benchmark's files under results/ (a hand-written snippet
    could carry a typed number); one that skips lines skips exactly the file's title line
    and the blank line after it (the page gives its own heading), so a table is never cut."""
    texts = {page: page.read_text(encoding="utf-8") for page in PAGES}
    for page, text in texts.items():  # every snippet in the one form the checks read
        lines = [line for line in text.splitlines() if "-8<-" in line]
        assert all(SNIPPET.fullmatch(line) for line in lines), (page.name, lines)
    snippets = [(page, path) for page, text in texts.items() for path in SNIPPET.findall(text)]
    assert snippets
    for page, path in snippets:
        name, _, lines = path.partition(":")
        assert name.startswith("results/") and (ROOT / name).is_file(), (page.name, path)
        if lines:
            assert lines == "3:", (page.name, path)
            head = (ROOT / name).read_text(encoding="utf-8").splitlines()
            assert head[0].startswith("# ") and head[1] == "", (page.name, path)


def test_the_readmes_python_runs_and_says_what_it_says():
    (block,) = [b for b in _blocks(README, "python") if "stream.push" in b]
    names = {}
    exec(compile(block, "README.md", "exec"), names)
    t, velocity, trusted = names["t"], names["velocity"], names["trusted"]
    truth = 2 * np.pi * 3 * np.cos(2 * np.pi * 3 * t)
    inside = (t > 0.3) & (t < 1.7)
    # noise 0.01 through a 10 Hz low-pass: ẋ within a few percent of its amplitude 18.8
    assert np.sqrt(np.mean((velocity[inside] - truth[inside]) ** 2)) < 0.05 * 2 * np.pi * 3
    assert trusted[inside].all()
    # the stream, fed the first 100 samples, gives the causal batch call's ẋ on them
    batch = methods.get("kalman_filter", bandwidth_hz=30.0)(names["x"][:100], 0.001, (1,))[1]
    np.testing.assert_array_equal(names["online"], batch)
    assert names["jacobi"].window_s == 0.21  # the paper's T (sec. III.C)


def test_the_readmes_method_registers_and_is_exact_on_a_parabola(tmp_path):
    """Run in a process of its own: registering a method changes the registry for good."""
    (block,) = [b for b in _blocks(README, "python") if "@register" in b]
    check = (
        "import numpy as np\n"
        "from diffbench import methods\n"
        "t = np.arange(0.0, 1.0, 0.001)\n"
        "estimate = methods.preset('my_package.box_difference', 'paper-signal')(t**2, 0.001)\n"
        "print(repr(float(estimate[1][500])), repr(float(estimate[2][500])))\n"
    )
    script = tmp_path / "readme_method.py"
    script.write_text(block + check)
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    result = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, env=env)
    assert result.returncode == 0, result.stderr
    first, second = map(float, result.stdout.split())
    # exact on degree 2 up to rounding: 41 box taps of the central difference, |taps|_1 =
    # 1/dt for ẋ and 4/dt² for ẍ, on values below 1: eps × taps × |taps|_1 × max|x|
    eps = np.finfo(float).eps
    assert abs(first - 2 * 0.5) <= 43 * eps * 1e3
    assert abs(second - 2.0) <= 43 * eps * 4e6


def test_the_methods_reference_has_every_method_parameter_and_preset():
    page = docs_site.methods_reference()
    sections = dict(re.findall(r"^## `([^`]+)`\n(.*?)(?=^## `|\Z)", page, re.S | re.M))
    assert set(sections) == set(methods.available(causal=None))
    for name, text in sections.items():
        cls = methods.method_class(name)
        for spec in methods.params_of(cls):
            assert f"| `{spec.name}` | {spec.default} |" in text, (name, spec.name)
        for key, preset in cls.presets.items():
            assert f"| `{key}` |" in text and preset.source.replace("|", "\\|") in text
        assert ("causal (online)" in text) == cls.causal


def test_the_methods_reference_draws_each_linear_methods_frequency_response():
    """A PNG for every linear method (at its paper-signal preset, else its defaults), none
    for a method without a response, and the section links the figure."""
    for name in methods.available(causal=None):
        figure = docs_site.response_figure(name)
        linear = methods.method_class(name).linear
        assert (figure is not None) == linear, name
        if figure is not None:
            assert figure.startswith(b"\x89PNG"), name
    setting, label = docs_site.response_setting("jacobi")
    assert setting == methods.preset("jacobi", "paper-signal") and "preset" in label
    assert "![frequency response of spectral](response-spectral.png)" in (
        docs_site.method_section("spectral", response=True)
    )


def test_each_results_folder_has_a_page_with_its_tables_and_figures():
    results = ROOT / "results"
    folders = docs_site.results_folders(results)
    assert results / "paper-signal" in folders
    assert results / "studies" / "grid" in folders
    assert not any("store" in folder.relative_to(results).parts for folder in folders)
    page = docs_site.results_page(results / "paper-signal", results)
    ranking = (ROOT / "results" / "paper-signal" / "ranking.md").read_text(encoding="utf-8")
    assert ranking.splitlines()[2] in page  # the table as written
    assert "![errors](errors.png)" in page
    index = docs_site.results_index(results)
    assert "(studies/grid/index.md)" in index


def test_the_site_builds_strictly(tmp_path):
    mkdocs = shutil.which("mkdocs", path=str(Path(sys.executable).parent))
    if mkdocs is None:
        pytest.skip("mkdocs is not installed (pip install 'diffbench[docs]'; make docs does)")
    # not --quiet: it drops MkDocs' warnings before strict mode counts them, so a broken link
    # or anchor would pass
    result = subprocess.run(
        [mkdocs, "build", "--strict", "--site-dir", str(tmp_path / "site")],
        cwd=ROOT,
        capture_output=True,
        text=True,
        env={**os.environ, "NO_MKDOCS_2_WARNING": "1"},
    )
    assert result.returncode == 0, result.stderr
    assert "WARNING" not in result.stderr, result.stderr
    grid = (tmp_path / "site" / "results" / "studies" / "grid" / "index.html").read_text()
    assert "Which differentiator on such records" in grid  # the study's tables, included
    home = (tmp_path / "site" / "index.html").read_text()
    assert "spectral" in home and "median" in home  # the generated table, included
    assert (tmp_path / "site" / "reference" / "methods.html").exists()  # opens from disk
    assert (tmp_path / "site" / "reference" / "response-jacobi.png").exists()
    assert (
        'src="response-jacobi.png"'
        in (tmp_path / "site" / "reference" / "methods.html").read_text()
    )
    assert 'href="results/index.html"' in home
    assert (tmp_path / "site" / "results" / "paper-signal" / "errors.png").exists()
    # the API reference, from the docstrings: every public name, no Sphinx role left as text
    api = (tmp_path / "site" / "reference" / "api.html").read_text()
    for name in ("methods.get", "methods.preset", "methods.register", "methods.Estimate"):
        assert f'id="diffbench.{name}"' in api, name
    assert 'id="diffbench.signals.get_scenario"' in api and 'id="diffbench.bench.api' in api
    assert not docs_site.SPHINX_ROLE.search(api) and ":func:" not in api
