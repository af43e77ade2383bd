"""Monte Carlo statistics over noise seeds: confidence intervals, paired comparisons with a
stated power, and rankings.

The significance decision between two entries is the two-sided paired t-test on the per-seed
differences (Student 1908). Its power is stated, not assumed: every comparison reports the
smallest true mean difference the test would detect with 80 % power at that number of seeds
(Owen 1965). The Wilcoxon signed-rank p-value (Wilcoxon 1945) is reported beside it as a
robustness check only; it is NaN where the test cannot reach the level at all (5 or fewer
nonzero differences at level 0.05), so a quick run with few seeds does not read as "no
difference" for want of seeds.

References
----------
Student (1908). The probable error of a mean. Biometrika 6(1), 1–25.
F. Wilcoxon (1945). Individual comparisons by ranking methods. Biometrics Bulletin 1(6), 80–83.
D. B. Owen (1965). The power of Student's t-test. J. Amer. Statist. Assoc. 60(309), 320–333.
"""

from __future__ import annotations

import math
import numbers

import numpy as np
import pandas as pd
from scipy import optimize, stats

from diffbench.signals._checks import check_whole

#: Columns ``ranking`` reads besides the entry keys.
_RANKING_COLUMNS = ("metric", "order", "region", "seed", "value")


def _check_level(level: float, name: str = "level") -> None:
    if not 0 < level < 1:
        raise ValueError(f"`{name}` must be in (0, 1), got {level}")


def confidence_interval(values, level: float = 0.95) -> tuple[float, float]:
    """Mean and half-width of the two-sided Student-t confidence interval of the mean.

    .. math:: \\bar v \\pm t_{(1+\\ell)/2,\\,N-1}\\; s / \\sqrt{N}

    (s the sample standard deviation). NaN half-width for fewer than 2 values.
    """
    values = np.asarray(values, dtype=float)
    if values.size == 0:
        raise ValueError("`values` is empty")
    _check_level(level)
    mean = float(np.mean(values))
    if values.size < 2:
        return mean, float("nan")
    half = stats.t.ppf((1 + level) / 2, values.size - 1) * np.std(values, ddof=1)
    return mean, float(half / math.sqrt(values.size))


def detectable_difference(n: int, std: float, level: float = 0.05, power: float = 0.8) -> float:
    """Smallest true mean difference the two-sided paired t-test detects with the given power.

    With ``n`` paired differences of standard deviation :math:`s_d`, the test rejects at level
    :math:`\\alpha` when :math:`|T| > t_{1-\\alpha/2,\\,n-1}`; under a true mean difference
    :math:`\\delta`, :math:`T` follows the noncentral t distribution with :math:`n-1` degrees of
    freedom and noncentrality :math:`\\lambda = \\delta\\sqrt n / s_d` (Owen 1965), so

    .. math::

        \\pi(\\delta) = P\\left(|T| > t_{1-\\alpha/2,\\,n-1}\\right)
                     = \\bar F_{n-1,\\lambda}(t_{1-\\alpha/2,\\,n-1})
                     + \\bar F_{n-1,-\\lambda}(t_{1-\\alpha/2,\\,n-1})

    (:math:`\\bar F_{\\nu,\\lambda}` the noncentral-t survival function). This returns the
    :math:`\\delta > 0` solving :math:`\\pi(\\delta) = ` ``power`` (``scipy.optimize.brentq`` on
    :math:`\\lambda`; :math:`\\pi` increases from :math:`\\alpha` at :math:`\\lambda = 0`
    towards 1). For large ``n`` it tends to the normal-theory value
    :math:`(z_{1-\\alpha/2} + z_{\\pi})\\, s_d/\\sqrt n`.

    Parameters
    ----------
    n : int
        Number of paired observations (seeds), ``n >= 0``. Fewer than 2 give NaN: no
        standard deviation, no test.
    std : float
        Standard deviation :math:`s_d` of the paired differences, finite and ``>= 0``. Zero (a
        deterministic difference, the same on every seed) gives 0: any nonzero difference is
        certain.
    level : float
        Two-sided significance level :math:`\\alpha`, in (0, 1).
    power : float
        Wanted power :math:`\\pi`, in (``level``, 1): the power at zero difference is ``level``.

    Returns
    -------
    float
        The detectable difference :math:`\\delta`, in the units of ``std``.

    References
    ----------
    D. B. Owen (1965). The power of Student's t-test. J. Amer. Statist. Assoc. 60(309), 320–333.

    Examples
    --------
    With many seeds it is :math:`(1.960 + 0.842)\\, s_d/\\sqrt n`, here 2.80 / 100:

    >>> round(detectable_difference(10_000, 1.0), 4)
    0.028
    >>> round(detectable_difference(5, 1.0), 3)  # 5 seeds: 1.68 standard deviations
    1.682
    >>> detectable_difference(1, 1.0), detectable_difference(5, 0.0)
    (nan, 0.0)
    """
    if isinstance(n, bool) or not isinstance(n, numbers.Integral):
        raise ValueError(f"`n` must be an integer, got {n!r}")
    if n < 0:
        raise ValueError(f"`n` must be >= 0, got {n}")
    std = float(std)
    if not (math.isfinite(std) and std >= 0):
        raise ValueError(f"`std` must be finite and >= 0, got {std}")
    _check_level(level)
    if not level < power < 1:
        raise ValueError(f"`power` must be in (`level`, 1) = ({level}, 1), got {power}")
    if n < 2:
        return float("nan")
    if std == 0:
        return 0.0
    df = int(n) - 1
    critical = stats.t.ppf(1 - level / 2, df)

    def shortfall(noncentrality: float) -> float:
        # the lower tail as the upper tail at -λ: scipy's nct.cdf can return NaN far out there
        rejection = stats.nct.sf(critical, df, noncentrality)
        return rejection + stats.nct.sf(critical, df, -noncentrality) - power

    upper = critical + stats.norm.ppf(power) + 1.0
    for _ in range(64):  # power → 1 as λ → ∞; doubling brackets the root in a few steps
        if shortfall(upper) > 0:
            break
        upper *= 2.0
    else:  # pragma: no cover - would take a noncentrality beyond 2**64
        raise RuntimeError(f"no noncentrality reaches power {power} with {n} seeds")
    noncentrality = optimize.brentq(shortfall, 0.0, upper, xtol=1e-12, rtol=1e-12)
    return float(noncentrality * std / math.sqrt(n))


def paired_comparison(first, second, level: float = 0.05) -> dict[str, float | bool]:
    """Paired comparison of two methods' scores over the same seeds, at level ``level``.

    With :math:`d_i = a_i - b_i` (``first`` − ``second``) over :math:`n` seeds, mean
    :math:`\\bar d` and standard deviation :math:`s_d`, the decision is the two-sided paired
    t-test (Student 1908)

    .. math:: T = \\frac{\\bar d}{s_d/\\sqrt n}, \\qquad
              p = 2\\,P(t_{n-1} > |T|), \\qquad \\text{significant} \\iff p < \\alpha,

    (``scipy.stats.ttest_rel``) and its power is stated as ``detectable_difference_80``
    (:func:`detectable_difference` at 80 % power with :math:`n` and :math:`s_d`).

    Returns
    -------
    dict
        ``mean_difference`` :math:`\\bar d`; ``t_p`` the t-test p-value — 0 when
        :math:`s_d = 0` and :math:`\\bar d \\ne 0` (the same nonzero difference on every seed
        leaves no doubt), NaN when every difference is 0 or :math:`n < 2`; ``significant``
        (``t_p < level``, so False when ``t_p`` is NaN); ``detectable_difference_80``;
        ``wilcoxon_p`` the two-sided Wilcoxon signed-rank p-value (Wilcoxon 1945; zero
        differences dropped), a robustness check outside the decision. Its smallest attainable
        value under the exact null distribution is :math:`2/2^m` for :math:`m` nonzero
        differences (every sign the same; ties cannot lower it), so where
        :math:`2/2^m \\ge` ``level`` (:math:`m \\le 5` at 0.05) the test cannot reach the
        level at all and ``wilcoxon_p`` is NaN rather than a p-value that looks like evidence
        of no difference.

    Examples
    --------
    Five seeds, ``first`` better by exactly 1 on each: certain, though no Wilcoxon test on 5
    seeds could say so (its smallest p is 2/32 > 0.05).

    >>> result = paired_comparison([1.0, 2.0, 3.0, 4.0, 5.0], [2.0, 3.0, 4.0, 5.0, 6.0])
    >>> result["mean_difference"], result["t_p"], result["significant"], result["wilcoxon_p"]
    (-1.0, 0.0, True, nan)
    """
    first, second = np.asarray(first, dtype=float), np.asarray(second, dtype=float)
    if first.shape != second.shape or first.ndim != 1:
        raise ValueError(
            "paired scores `first` and `second` must be 1-D arrays over the same "
            f"seeds, got shapes {first.shape} and {second.shape}"
        )
    _check_level(level)
    difference = first - second
    n = difference.size
    nan = float("nan")
    mean = float(np.mean(difference)) if n else nan
    if n < 2:
        t_p, std = nan, nan
    elif np.ptp(difference) == 0:  # the same difference on every seed: s_d is exactly 0
        t_p, std = (nan if mean == 0 else 0.0), 0.0
    else:
        t_p, std = float(stats.ttest_rel(first, second).pvalue), float(np.std(difference, ddof=1))
    nonzero = int(np.count_nonzero(difference))
    if 2.0 / 2.0**nonzero >= level:  # the exact test cannot reach the level with so few
        wilcoxon_p = nan
    else:
        wilcoxon_p = float(stats.wilcoxon(first, second).pvalue)
    detectable = detectable_difference(n, std, level) if math.isfinite(std) else nan
    return {
        "mean_difference": mean,
        "t_p": t_p,
        "wilcoxon_p": wilcoxon_p,
        "detectable_difference_80": detectable,
        "significant": bool(t_p < level),
    }


RANK_DIGITS = 10
"""Means that agree to this many significant digits rank as ties, in the order of their keys
(:func:`ranking`): one computation reached by two paths (a setting rounded otherwise, a sum
taken in another order) differs in its last bits, and the entries would otherwise swap places
from one run to the next. A ranking's differences that matter are larger by many orders."""


def ranking(
    rows: pd.DataFrame,
    metric: str,
    order: int,
    region: str,
    keys=("method", "params"),
    level: float = 0.05,
    compared: int | None = None,
) -> pd.DataFrame:
    """Entries ranked by the mean of ``metric`` over seeds (smaller is better; means equal to
    ``RANK_DIGITS`` significant digits in the order of their keys), each with its
    95 % confidence interval and a paired t-test against the next one down, with stated power.

    An entry is one combination of the ``keys`` columns (e.g. ``("method", "params")``, or
    ``("method", "params", "role")``). Each entry's rows for ``metric``/``order``/``region``
    give one value per seed; an entry with two rows for one seed is an error, never averaged.
    Entry :math:`k` is compared with entry :math:`k+1` over the seeds both have
    (:func:`paired_comparison` at ``level``): the decision is the two-sided paired t-test,
    :math:`p < \\alpha`; ``detectable_difference_80`` is the true mean difference that test
    would detect with 80 % power at that number of common seeds and the observed standard
    deviation of the paired differences (:func:`detectable_difference`), so "not significant"
    can be read against it; the Wilcoxon p-value is a robustness check outside the decision,
    NaN where it cannot reach ``level`` at that number of seeds.

    Parameters
    ----------
    rows : pandas.DataFrame
        Tidy results with the ``keys`` columns and ``metric``, ``order``, ``region``, ``seed``,
        ``value``; an optional ``preset`` column (not among ``keys``) is carried along as a
        label (the first row's value per entry).
    metric, order, region : str, int, str
        Which scores to rank.
    keys : sequence of str
        Columns identifying one entry, at least one; each must be a column of ``rows``.
    level : float
        Two-sided significance level of the t-test, in (0, 1).
    compared : int, optional
        Compare only the first ``compared`` entries with the next one down (a caller that reads
        the winner's test alone: 1); the later rows' comparison columns are NaN / NA, every
        other column is the same. Default: every entry.

    Returns
    -------
    pandas.DataFrame
        One row per entry, best first: the ``keys`` columns, ``preset`` (when ``rows`` has
        it), ``mean``, ``ci95`` (Student-t half-width, :func:`confidence_interval`), ``seeds``,
        then for the comparison with the next row over their common seeds
        ``vs_next_mean_difference`` (this − next), ``vs_next_t_p``, ``vs_next_wilcoxon_p``,
        ``detectable_difference_80`` and ``significant_vs_next`` (pandas nullable boolean;
        False when fewer than 2 common seeds; NA, like the other comparison columns' NaN, on
        the last row).
    """
    if isinstance(keys, str):
        raise ValueError(f"`keys` must be a sequence of column names, got the string {keys!r}")
    keys = list(keys)
    if not keys:
        raise ValueError("`keys` must name at least one column, got none")
    for column in (*keys, *_RANKING_COLUMNS):
        if column not in rows.columns:
            raise ValueError(
                f"`rows` has no column {column!r} (needed by `keys` or the "
                f"ranking); it has {list(rows.columns)}"
            )
    _check_level(level)
    if compared is not None:
        compared = check_whole("compared", compared, ge=0)
    chosen = rows[
        (rows["metric"] == metric) & (rows["order"] == order) & (rows["region"] == region)
    ]
    if chosen.empty:
        raise ValueError(f"no stored rows for {metric!r}, order {order}, region {region!r}")
    labelled = "preset" in chosen.columns and "preset" not in keys
    series, records = [], []
    for entry, group in chosen.groupby(keys, sort=True, dropna=False):
        repeated = group["seed"][group["seed"].duplicated()].unique()
        if repeated.size:
            where = dict(zip(keys, entry, strict=True))
            raise ValueError(
                f"duplicated seeds {sorted(repeated.tolist())} for entry {where} "
                f"({metric!r}, order {order}, region {region!r}): each seed must "
                "appear once per entry"
            )
        values = group.set_index("seed")["value"].sort_index()
        mean, half = confidence_interval(values.to_numpy())
        record = dict(zip(keys, entry, strict=True))
        if labelled:
            record["preset"] = group["preset"].iloc[0]
        record.update(
            {"mean": mean, "ci95": half, "seeds": int(values.size), "_entry": len(series)}
        )
        series.append(values)
        records.append(record)
    table = pd.DataFrame(records)
    # equal to RANK_DIGITS significant digits: a tie, in the order of the keys (groupby's)
    table["_rank"] = [float(f"{mean:.{RANK_DIGITS - 1}e}") for mean in table["mean"]]
    table = table.sort_values(["_rank", "_entry"], kind="stable").reset_index(drop=True)
    comparisons = []
    last = len(table) - 1 if compared is None else min(compared, len(table) - 1)
    uncompared = len(table) - last  # rows without a comparison: NaN / NA
    for k in range(last):
        a, b = series[table["_entry"].iloc[k]], series[table["_entry"].iloc[k + 1]]
        common = a.index.intersection(b.index)
        result = paired_comparison(a[common].to_numpy(), b[common].to_numpy(), level)
        if table["_rank"].iloc[k] == table["_rank"].iloc[k + 1]:
            # a tie: a difference in the last bits, the same on every seed, is no evidence
            result = {**result, "t_p": math.nan, "wilcoxon_p": math.nan, "significant": False}
        comparisons.append(result)
    table = table.drop(columns="_rank")
    nan = [float("nan")] * uncompared
    for column, field in (
        ("vs_next_mean_difference", "mean_difference"),
        ("vs_next_t_p", "t_p"),
        ("vs_next_wilcoxon_p", "wilcoxon_p"),
        ("detectable_difference_80", "detectable_difference_80"),
    ):
        table[column] = [result[field] for result in comparisons] + nan
    table["significant_vs_next"] = pd.array(
        [result["significant"] for result in comparisons] + [pd.NA] * uncompared,
        dtype="boolean",
    )
    return table.drop(columns="_entry")
