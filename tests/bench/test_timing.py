"""The throughput table: every method gets a figure, sizes past a cap are left out and said."""

import numpy as np

from diffbench.bench import timing


def test_a_method_capped_below_the_smallest_size_is_timed_at_its_cap(tmp_path, monkeypatch):
    monkeypatch.setitem(timing.SIZE_CAPS, "finite_difference", (1000, "a cap for this test"))
    table = timing.throughput(sizes=(2000, 4000), repeats=1,
                              names=["finite_difference", "savitzky_golay"])  # fmt: skip
    timed = table.groupby("method")["samples"].apply(list).to_dict()
    assert timed == {"finite_difference": [1000], "savitzky_golay": [2000, 4000]}
    assert np.all(table["samples_per_s"] > 0)
    assert np.allclose(table["samples_per_s"], table["samples"] / table["seconds"])
    markdown = (timing.write_throughput(tmp_path, table)[0]).read_text(encoding="utf-8")
    rows = {line.split(" | ")[0].lstrip("| "): line for line in markdown.splitlines()}
    assert "| 1e+03 | 2e+03 | 4e+03 | growth |" in markdown
    # one size timed: no growth, and the two sizes it was not timed at are dashes
    assert rows["finite_difference"].endswith("| — | — | — |")
    assert not rows["savitzky_golay"].endswith("| — |")
    assert rows["savitzky_golay"].split(" | ")[2] == "—"  # not timed at the 1000-sample column
    assert "- finite_difference: timed up to 1000 samples (a cap for this test)" in markdown
