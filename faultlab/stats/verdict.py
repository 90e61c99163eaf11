"""Per-case verdicts from K repetitions with common random numbers, and clustered false-alarm rates.

Beyond the paper (Sec. VII-A compares one faulty with one baseline run per case): with ``K``
SLAM repetitions per case and common random numbers (repetition ``r`` of every variant uses the
same seed, hence the same random stream for every unit the fault does not replace), the errors
pair naturally by repetition.  A fault is **detected on a case** when an exact paired test of its
``K`` errors against the baseline's ``K`` errors rejects at ``alpha``: two-sided by default
(``direction = "either"``: the variant behaves differently, its map is worse *or* better -- in
mutation analysis a mutant is killed when its behaviour is distinguishable), or one-sided
(``direction = "worse"``: the paper's notion, Sec. VII-A, "the faulty implementation's map error
exceeds the baseline's").  Every verdict carries the observed direction (``worse``/``better``)
and the paired effect: the median difference (mm) and the median ratio faulty / baseline, each
with a distribution-free order-statistic interval (:func:`median_interval`).

The test: exact sign-flip (paired permutation) test
---------------------------------------------------
Differences ``d_r = faulty_r - baseline_r`` (mm), statistic ``mean(d)``; alternative
``two-sided`` (p = twice the smaller one-sided p value, at most 1) or "the fault makes the map
worse" (``greater``).  Under the null hypothesis the fault does not change the
error distribution of a repetition, so each ``d_r`` is symmetric about 0 and, given the
``|d_r|``, every one of the ``2^K`` sign patterns is equally likely.  The exact p value is the
share of the ``2^K`` sign patterns whose mean is at least the observed one, computed by
:func:`scipy.stats.permutation_test` (``permutation_type="samples"`` with one sample flips signs,
``n_resamples=np.inf`` enumerates all patterns), whose values :mod:`faultlab.inference.signflip`
reproduces bit for bit from two halves of the pairs without enumerating them.  Why this test rather than the Wilcoxon
signed-rank test: both have the same smallest attainable p value, but with *zero differences*
(a fault that does not change a repetition's output is bit-identical to the baseline under common
random numbers, so zeros are common) or *tied* ``|d|`` SciPy's exact signed-rank distribution is
invalid and SciPy switches to a normal approximation, whereas the sign-flip enumeration is exact
in every case.  The mean also keeps the size of the differences, which is the effect reported.

Ties and zeros, exactly:

* a zero difference is kept: flipping it changes nothing, so it doubles both the number of
  patterns at least as extreme and the total -- the p value equals that of the test on the
  non-zero differences only; if every difference is 0 the p value is 1;
* tied ``|d|`` need no treatment (the statistic uses the values, not ranks); patterns whose mean
  equals the observed one count as "at least as extreme" (SciPy compares with a relative
  tolerance of about 1e-14 so that sums of the same numbers in another order still tie).

Smallest attainable p value: one-sided ``2^-K`` (all differences positive), more precisely
``2^-(number of non-zero differences)``; two-sided twice that (all positive or all negative);
:func:`min_p_value`.  A verdict at level ``alpha`` is therefore possible only from
:func:`min_pairs` usable pairs, one more two-sided than one-sided:

======  ==============  ==============  ==============================
K       one-sided min   two-sided min   largest n with min p <= 0.05/n
                                        (one-sided / two-sided)
======  ==============  ==============  ==============================
5       0.03125         0.0625          1 / 0
7       0.0078          0.0156          6 / 3
8       0.0039          0.0078          12 / 6
10      0.00098         0.00195         51 / 25
11      0.00049         0.00098         102 / 51
======  ==============  ==============  ==============================

A shipped experiment's K is derived from :func:`min_pairs` at the per-case level its decision
uses (e.g. ``alpha / n`` for Holm's first step over ``n`` cases).

Enumerating ``2^K`` patterns limits the exact test to ``K <= MAX_EXACT_PAIRS`` (20).

Outcome of a (case, fault) (:class:`Verdict`)
---------------------------------------------
A repetition of a variant is *usable* when its job finished ``ok`` with a finite error (a job
``ok`` without a finite error mapped nothing and counts as a failure, as in
:mod:`faultlab.stats.detection`).

``cannot_judge``
    The baseline is unusable (crashed, timed out, mapped nothing, or missing) in **any**
    repetition of the case -- the case makes the reference itself fail, so neither a failure nor
    an error of the faulty variant is evidence of the fault (``reason = "baseline_failed"``) --
    or the faulty variant ran normally but fewer than :func:`min_pairs` pairs are usable, so no
    outcome of the test could reject at ``alpha`` (``reason = "too_few_pairs"``).  Such cases
    are reported as such, never as misses.
``crash_detected``
    The baseline is usable in every repetition and the faulty variant failed (crash, timeout or
    no usable map) in at least one: a failure of the faulty variant alone is an observable
    failure, so it **counts as a detection**.
``detected`` / ``not_detected``
    Otherwise the exact test above decides (p <= alpha) -- or, on a deterministic case, the
    exact difference (below).

Deterministic cases: judged exactly
-----------------------------------
A deterministic SLAM (EKF-SLAM, iSAM2, dead reckoning) gives the same map whatever the seed, so
its K repetitions of a case are copies of one execution: a test over them would count one
observation K times (a sign-flip p of ``2^-(K-1)`` from ten copies of one difference).  A case
whose baseline and variant each gave bit-identical errors in every one of at least two
repetitions is judged by its difference instead (``test = "exact"``): ``detected`` when the
variant's error differs from the baseline's at all, ``not_detected`` when it is the same; no p
value, no interval (the difference is known, not estimated), and any shift would have been
detected (``mde_mm = 0``).  The other cases are judged by the sign-flip test
(``test = "sign-flip"``).  Evidence over a deterministic SLAM's cases takes the cases as the unit
(:mod:`faultlab.stats.pooling`), never its repetitions.

No multiplicity correction is applied: each (case, fault) is one test with false-positive rate
at most ``alpha``, which is what a detection *rate* over cases needs.

Smallest detectable shift
-------------------------
Per case, ``mde_mm`` is the smallest shift ``delta`` of the paired differences that the test
detects with probability ``power`` (default :data:`~faultlab.vocabulary.DEFAULT_POWER`) at ``alpha``, under the model
``d_r = delta + e_r`` with ``e_r ~ N(0, sigma^2)`` i.i.d.  ``sigma`` is estimated from the
baseline's own variability: ``sigma = sqrt(2) * s_b`` with ``s_b`` the standard deviation
(ddof = 1) of the baseline's K errors on the case -- the spread of the difference of two
independent runs.  A fault that makes the run diverge from the baseline's early makes the
faulty error behave like that of an independent run; common random numbers can only reduce the
spread where the fault acts late, so the figure is conservative.  ``mde = c(K) * sigma`` where
``c(K)`` (:func:`detectable_shift_factor`) is computed for ``sigma = 1``:

* ``K <= 12``: by simulation with a fixed generator (``SeedSequence(MDE_SEED)``, 4000 draws of
  ``e``).  For one draw the test rejects exactly when ``delta > v_(m)``, the ``m``-th largest of
  ``-mean(e_F)`` over the non-empty subsets ``F`` of repetitions, ``m = floor(alpha 2^K)``
  (flipping the signs of ``F`` gives a mean at least the observed one iff
  ``sum_F (e_r + delta) <= 0``); ``c(K)`` is the ``power``-quantile of ``v_(m)`` over the draws;
* ``K > 12``: the paired t test's power (noncentral t, statsmodels ``TTestPower``), to which the
  sign-flip test converges (they agree within 2 % from K = 10 on);
* ``c(K) = inf`` when ``2^-K > alpha``: no shift is detectable.

Clustered false-alarm rate
--------------------------
:func:`clustered_rate` gives an A/A false-alarm rate (baseline against baseline) with a
confidence interval that accounts for the pairs of one case being correlated (see there).
"""

from __future__ import annotations

import math
import numbers
from enum import StrEnum

import numpy as np
import pandas as pd

from faultlab.errors import ConfigError, ResultsError
from faultlab.inference.exact import (MAX_EXACT_PAIRS, alternative_of, check_alpha, check_count,
                                      detectable_shift_factor, min_p_value, min_pairs, sign_flip_pvalues)
from faultlab.inference.intervals import median_interval
from faultlab.runner.store import usable_rows
from faultlab.vocabulary import BASELINE, DEFAULT_ALPHA, DEFAULT_DIRECTION, DEFAULT_POWER, METRICS, Change, JobStatus

__all__ = ["Verdict", "TOO_FEW_PAIRS", "SIGN_FLIP", "EXACT", "EQUIVALENCE_MARGIN_REL", "EQUIVALENCE_MARGIN_MM", "case_verdicts"]

#: ``reason`` of a ``cannot_judge`` verdict whose usable pairs are fewer than :func:`min_pairs`.
TOO_FEW_PAIRS = "too_few_pairs"
#: ``test`` of a case judged by the exact sign-flip test over its K repetitions.
SIGN_FLIP = "sign-flip"
#: ``test`` of a deterministic case judged by its exact difference (no test over repetitions).
EXACT = "exact"

_COLUMNS = ["suite", "run", "case", "fault", "verdict", "reason", "test", "detected", "alternative", "direction", "n_reps",
            "n_failed", "n_pairs", "mean_diff_mm", "mean_log_ratio", "median_diff_mm", "median_low_mm",
            "median_high_mm", "ratio",
            "ratio_low", "ratio_high", "ci_coverage", "p", "p_min", "baseline_sd_mm", "mde_mm", "identical",
            "margin_mm", "p_equivalence"]

#: Default equivalence margin relative to the baseline's median error on the case (10 %): a change
#: of the map error within +-10 % of its level is "equivalent" (TOST, :func:`case_verdicts`).
EQUIVALENCE_MARGIN_REL = 0.10
#: Default absolute equivalence margin, mm (none: the relative margin alone).
EQUIVALENCE_MARGIN_MM = 0.0

class Verdict(StrEnum):
    """Outcome of one fault on one case over K repetitions (see the module docstring)."""

    DETECTED = "detected"
    NOT_DETECTED = "not_detected"
    CRASH_DETECTED = "crash_detected"
    CANNOT_JUDGE = "cannot_judge"


def case_verdicts(results: pd.DataFrame, *, alpha: float = DEFAULT_ALPHA, metric: str = "rms", power: float = DEFAULT_POWER,
                  min_pairs_required: int | None = None, direction: str = DEFAULT_DIRECTION,
                  mde_alpha: float | None = None, margin_rel: float = EQUIVALENCE_MARGIN_REL,
                  margin_mm: float = EQUIVALENCE_MARGIN_MM) -> pd.DataFrame:
    """Verdict of every fault on every case from the K repetitions (exact paired sign-flip test).

    Parameters
    ----------
    results : DataFrame
        The runner's results; needs ``run, suite, case, rep, variant, status`` and the
        metric's column (``rms_mm``, ``emd_mm`` or ``ate_mm``).  One row per job.
    alpha : float
        Level of each test, in (0, 1).
    metric : {"rms", "emd", "ate"}
        The map error compared.
    power : float
        Power of the reported smallest detectable shift, in (0, 1).
    min_pairs_required : int, optional
        Fewest usable pairs for a verdict; never fewer than :func:`min_pairs` ``(alpha)`` (the
        default), below which no outcome could reject.
    direction : {"either", "worse"}
        ``"either"`` (default): two-sided test, a variant that changes the error in either
        direction is detected; ``"worse"``: the paper's one-sided notion (the error grows).
    mde_alpha : float, optional
        Per-test level of the decision the smallest detectable shift is for (e.g. Holm's first
        step ``alpha / n`` over a family of ``n`` cases); default ``alpha``.
    margin_rel, margin_mm : float
        Equivalence margin ``delta = max(margin_mm, margin_rel * median baseline error)`` of the
        case, mm (defaults :data:`EQUIVALENCE_MARGIN_REL` = 10 %, :data:`EQUIVALENCE_MARGIN_MM`).
        Two one-sided tests (TOST) with the exact sign-flip test on the shifted differences:
        ``H0: shift <= -delta`` ("greater" on ``d + delta``) and ``H0: shift >= +delta``
        ("less" on ``d - delta``); ``p_equivalence`` is the larger p value, and the variant is
        equivalent within ``+-delta`` on the case when it is at most ``alpha``.  With ``K``
        pairs TOST can succeed only when ``2^-K <= alpha`` and ``delta`` exceeds the noise of
        the mean difference; otherwise "not detected" stays "no difference shown".

    Returns
    -------
    DataFrame
        One row per (suite, run, case, fault), sorted by those: ``verdict`` (:class:`Verdict`
        value), ``reason`` (``"baseline_failed"`` / ``"too_few_pairs"`` for ``cannot_judge``,
        else ""), ``test`` (:data:`SIGN_FLIP`, :data:`EXACT` for a deterministic case judged by its
        difference, "" where nothing was tested), ``detected`` (nullable boolean: True for detected
        and crash_detected, False for not_detected, NA for cannot_judge), ``alternative`` (the test's: ``two-sided`` or
        ``greater``), ``direction`` (:class:`~faultlab.vocabulary.Change` value: the sign of the
        mean difference over the usable pairs, ``none`` when it is 0 or there is none),
        ``n_reps`` (faulty jobs), ``n_failed`` (faulty jobs without a usable error),
        ``n_pairs`` (usable pairs), ``mean_diff_mm``, ``mean_log_ratio`` (mean of
        ``log(faulty / baseline)``, the case's contribution to the pooled suite test of
        :mod:`faultlab.stats.pooling`), ``median_diff_mm`` (over the usable pairs)
        with its order-statistic interval ``median_low_mm, median_high_mm`` (:func:`median_interval`
        at ``1 - alpha``, exact coverage ``ci_coverage``), ``ratio`` (median over the pairs of
        faulty / baseline error) with ``ratio_low, ratio_high`` (the same order statistics of the
        ratios) -- the effect intervals are NaN for untested cases and where every difference is
        0 (bit-identical runs: no interval to estimate) --, ``identical`` (every repetition ran
        and every paired error equals the baseline's bit for bit), ``margin_mm`` and
        ``p_equivalence`` (TOST, see ``margin_rel``; NaN where not tested), ``p`` (exact p value of the chosen
        alternative; NaN where not tested), ``p_min`` (``2^-n_pairs``), ``baseline_sd_mm`` (std of the baseline's errors
        on the case, ddof = 1) and ``mde_mm`` (smallest shift detectable with ``power``; inf
        when ``n_pairs`` is too small, NaN when the baseline failed or has one repetition; a written
        table shows both as a blank cell, :func:`faultlab.precision.write_csv`).

    Raises
    ------
    ResultsError
        Missing columns, a job that appears twice, or an unknown status.
    ConfigError
        Bad ``alpha``, ``metric``, ``power`` or ``min_pairs_required``, or more than
        :data:`MAX_EXACT_PAIRS` usable pairs in a case.
    """
    alpha = check_alpha(alpha, "case_verdicts")
    alternative = alternative_of(direction)
    for name, value in (("margin_rel", margin_rel), ("margin_mm", margin_mm)):
        if isinstance(value, bool) or not isinstance(value, numbers.Real) or not 0 <= value < math.inf:
            raise ConfigError(f"case_verdicts: {name} must be a finite number >= 0, got {value!r}")
    mde_alpha = alpha if mde_alpha is None else check_alpha(mde_alpha, "case_verdicts")
    if metric not in METRICS:
        raise ConfigError(f"case_verdicts: metric must be one of {list(METRICS)}, got {metric!r}")
    if isinstance(power, bool) or not isinstance(power, numbers.Real) or not 0 < power < 1:
        raise ConfigError(f"case_verdicts: power must lie in (0, 1), got {power!r}")
    gate = min_pairs(alpha, alternative=alternative)
    if min_pairs_required is not None:
        gate = max(gate, check_count(min_pairs_required, "case_verdicts", "min_pairs_required"))
    col = f"{metric}_mm"
    if not isinstance(results, pd.DataFrame):
        raise ResultsError(f"case_verdicts: results must be a pandas DataFrame, got {type(results).__name__}")
    need = ["run", "suite", "case", "rep", "variant", "status", col]
    missing = [c for c in need if c not in results.columns]
    if missing:
        raise ResultsError(f"case_verdicts: results lack column(s) {', '.join(missing)}")
    df = results[need].copy()
    unknown = sorted(set(df["status"].astype(str)) - {s.value for s in JobStatus})
    if unknown:
        raise ResultsError(f"case_verdicts: unknown status {unknown[0]!r} (expected ok, crash or timeout)")
    dup = df.duplicated(["run", "suite", "case", "rep", "variant"], keep=False)
    if dup.any():
        row = df.loc[dup].iloc[0]
        raise ResultsError(f"case_verdicts: job run={row['run']}, suite={row['suite']}, case={row['case']}, "
                           f"rep={row['rep']}, variant={row['variant']} appears more than once")
    case_key = ["suite", "run", "case"]
    df["usable"] = usable_rows(df, col)
    is_base = (df["variant"] == BASELINE).to_numpy()
    base = df.loc[is_base, case_key + ["rep", col, "usable"]]
    faulty = df.loc[~is_base].rename(columns={"variant": "fault"})
    if faulty.empty:
        return pd.DataFrame(columns=_COLUMNS)
    base_stats = base.groupby(case_key).agg(base_all_ok=("usable", "all"), baseline_sd_mm=(col, "std"),
                                            baseline_median_mm=(col, "median"), n_base=("usable", "size"),
                                            base_min=(col, "min"), base_max=(col, "max"))
    pairs = faulty.merge(base.rename(columns={col: "base_value", "usable": "base_usable"}),
                         on=case_key + ["rep"], how="left")
    pairs["base_usable"] = pairs["base_usable"].astype("boolean").fillna(False).astype(bool)
    pairs["pair_ok"] = pairs["usable"] & pairs["base_usable"]
    pairs["diff"] = np.where(pairs["pair_ok"], pairs[col].to_numpy(float) - pairs["base_value"].to_numpy(float),
                             np.nan)
    pairs["abs_diff"] = np.abs(pairs["diff"].to_numpy(float))
    with np.errstate(divide="ignore", invalid="ignore"):
        log_ratio = np.log(pairs[col].to_numpy(float) / pairs["base_value"].to_numpy(float))
    pairs["log_ratio"] = np.where(pairs["pair_ok"].to_numpy(bool) & np.isfinite(log_ratio), log_ratio, np.nan)
    key = case_key + ["fault"]
    g = pairs.groupby(key, sort=True)
    table = g.agg(n_reps=("usable", "size"), n_usable=("usable", "sum"), all_base_paired=("base_usable", "all"),
                  n_pairs=("pair_ok", "sum"), mean_diff_mm=("diff", "mean"),
                  median_diff_mm=("diff", "median"), max_abs_diff=("abs_diff", "max"),
                  mean_log_ratio=("log_ratio", "mean"), faulty_min=(col, "min"),
                  faulty_max=(col, "max")).reset_index()
    table["n_failed"] = table["n_reps"] - table["n_usable"]
    table = table.merge(base_stats.reset_index(), on=case_key, how="left")
    base_ok = (table["base_all_ok"].astype("boolean").fillna(False).to_numpy(bool)
               & table["all_base_paired"].to_numpy(bool))
    n_pairs = table["n_pairs"].to_numpy(np.int64)
    n_failed = table["n_failed"].to_numpy(np.int64)

    verdict = np.full(len(table), Verdict.NOT_DETECTED.value, dtype=object)
    reason = np.full(len(table), "", dtype=object)
    crashed = base_ok & (n_failed > 0)
    # a deterministic case: every repetition of the baseline and of the variant gave the same error, bit for
    # bit (two or more of each), so its K repetitions are copies of one execution: judged by the difference
    exact = (base_ok & ~crashed & (n_pairs >= 2) & (n_pairs == table["n_reps"].to_numpy(np.int64))
             & (table["base_min"].to_numpy(float) == table["base_max"].to_numpy(float))
             & (table["faulty_min"].to_numpy(float) == table["faulty_max"].to_numpy(float)))
    too_few = base_ok & ~crashed & ~exact & (n_pairs < gate)
    tested = base_ok & ~crashed & ~too_few & ~exact
    verdict[crashed] = Verdict.CRASH_DETECTED.value
    verdict[too_few] = Verdict.CANNOT_JUDGE.value
    reason[too_few] = TOO_FEW_PAIRS
    verdict[~base_ok] = Verdict.CANNOT_JUDGE.value
    reason[~base_ok] = "baseline_failed"

    p = np.full(len(table), np.nan)
    eff = {name: np.full(len(table), np.nan) for name in ("median_low_mm", "median_high_mm", "ratio", "ratio_low",
                                                           "ratio_high", "ci_coverage", "p_equivalence")}
    margin = np.maximum(float(margin_mm), float(margin_rel) * table["baseline_median_mm"].to_numpy(float))
    if tested.any():
        too_many = n_pairs[tested].max()
        if too_many > MAX_EXACT_PAIRS:
            raise ConfigError(f"case_verdicts: a case has {too_many} usable pairs; the exact sign-flip test "
                              f"enumerates 2^K patterns and is limited to K <= {MAX_EXACT_PAIRS}")
        # the differences of each tested (case, fault) as one row of a (groups, K) matrix, per K
        rows = table.reset_index(drop=True).assign(_row=np.arange(len(table)))[key + ["_row"]]
        sel = pairs.merge(rows, on=key)
        sel = sel[sel["pair_ok"].to_numpy() & tested[sel["_row"].to_numpy()]]
        row = sel["_row"].to_numpy()
        pos = sel.groupby("_row").cumcount().to_numpy()
        diff = sel["diff"].to_numpy(float)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = sel[col].to_numpy(float) / sel["base_value"].to_numpy(float)
        for k in np.unique(n_pairs[tested]):
            groups = np.flatnonzero(tested & (n_pairs == k))
            local = np.full(len(table), -1)
            local[groups] = np.arange(groups.size)
            take = local[row] >= 0
            mat = np.empty((groups.size, k))
            mat[local[row[take]], pos[take]] = diff[take]
            p[groups] = sign_flip_pvalues(mat, alternative=alternative)
            rat = np.empty((groups.size, k))
            rat[local[row[take]], pos[take]] = ratio[take]
            lo, hi, cover = median_interval(mat, level=1 - alpha)
            rlo, rhi, _ = median_interval(rat, level=1 - alpha)
            varies = np.any(mat != 0, axis=1)
            eff["median_low_mm"][groups] = np.where(varies, lo, np.nan)
            eff["median_high_mm"][groups] = np.where(varies, hi, np.nan)
            eff["ratio"][groups] = np.median(rat, axis=1)
            eff["ratio_low"][groups] = np.where(varies, rlo, np.nan)
            eff["ratio_high"][groups] = np.where(varies, rhi, np.nan)
            eff["ci_coverage"][groups] = np.where(varies, cover, np.nan)
            delta = margin[groups][:, None]
            eff["p_equivalence"][groups] = np.maximum(sign_flip_pvalues(mat + delta, alternative="greater"),
                                                      sign_flip_pvalues(mat - delta, alternative="less"))
        hit = tested & (p <= alpha)
        verdict[hit] = Verdict.DETECTED.value
    mean_diff = table["mean_diff_mm"].to_numpy(float)
    verdict[exact & (mean_diff != 0)] = Verdict.DETECTED.value
    with np.errstate(divide="ignore", invalid="ignore"):
        exact_ratio = table["faulty_min"].to_numpy(float) / table["base_min"].to_numpy(float)
    eff["ratio"][exact] = exact_ratio[exact]

    detected = pd.array(np.isin(verdict, [Verdict.DETECTED.value, Verdict.CRASH_DETECTED.value]), dtype="boolean")
    detected[verdict == Verdict.CANNOT_JUDGE.value] = pd.NA
    sd = table["baseline_sd_mm"].to_numpy(float)
    factor = np.full(len(table), math.inf)  # no usable pair: nothing is detectable
    for k in np.unique(n_pairs[(n_pairs >= 1)]):
        factor[n_pairs == k] = (detectable_shift_factor(int(k), alpha=mde_alpha, power=power,
                                                        alternative=alternative)
                                if k <= MAX_EXACT_PAIRS else math.nan)
    with np.errstate(invalid="ignore"):
        mde = np.where(base_ok & np.isfinite(sd), factor * math.sqrt(2.0) * sd, np.nan)
    out = table[key].copy()
    out["verdict"] = verdict
    out["reason"] = reason
    out["test"] = np.where(exact, EXACT, np.where(tested, SIGN_FLIP, "")).astype(object)
    out["detected"] = detected
    out["alternative"] = alternative
    out["direction"] = np.where(mean_diff > 0, Change.WORSE.value,
                                np.where(mean_diff < 0, Change.BETTER.value, Change.NONE.value)).astype(object)
    out["n_reps"] = table["n_reps"].to_numpy(np.int64)
    out["n_failed"] = n_failed
    out["n_pairs"] = n_pairs
    out["mean_diff_mm"] = table["mean_diff_mm"].to_numpy(float)
    out["mean_log_ratio"] = table["mean_log_ratio"].to_numpy(float)
    out["median_diff_mm"] = table["median_diff_mm"].to_numpy(float)
    for name, values in eff.items():
        out[name] = values
    out["p"] = p
    out["p_min"] = np.where(exact, np.nan, min_p_value(n_pairs, alternative=alternative))
    out["baseline_sd_mm"] = np.where(base_ok, sd, np.nan)
    out["mde_mm"] = np.where(exact, 0.0, mde)  # a deterministic case: any change of the error shows
    out["identical"] = (base_ok & (n_failed == 0) & (n_pairs == table["n_reps"].to_numpy(np.int64)) & (n_pairs > 0)
                        & (table["max_abs_diff"].to_numpy(float) == 0))
    out["margin_mm"] = np.where(base_ok, margin, np.nan)
    return out[_COLUMNS].reset_index(drop=True)
