"""Sensitivity indices of a response over a designed experiment: Morris screening and Sobol indices.

Every index comes from SALib's estimators on the design of :mod:`faultlab.space.design` (one
response value per design point, i.e. per test case):

* **Morris** (:func:`SALib.analyze.morris.analyze`): ``mu*``, the mean absolute elementary effect of
  a parameter (how much the response moves when the parameter's unit coordinate jumps by
  ``p / (2 (p - 1))``), its bootstrap confidence interval over trajectories, and ``sigma``, the
  spread of the elementary effects (non-linearity or interaction).  Screening keeps the
  parameters with the largest ``mu*`` (:func:`screen`).
* **Sobol** (:func:`SALib.analyze.sobol.analyze`, Saltelli's design, no second order): the
  first-order index ``S1`` (share of the response variance explained by the parameter alone)
  and the total index ``ST`` (share it takes part in, interactions included), each with its
  bootstrap interval.

The repetitions' noise enters every index: a parameter with no effect still has a total index
near ``noise / Var(response)``.  :func:`noise_floor` estimates that share from the per-case
standard errors, so a reader can tell a small index from noise.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np

from faultlab.errors import ResultsError

__all__ = ["MORRIS_COLUMNS", "SOBOL_COLUMNS", "Indices", "morris_indices", "sobol_indices", "screen", "noise_floor"]

MORRIS_COLUMNS: tuple[str, ...] = ("parameter", "mu_star", "mu_star_low", "mu_star_high", "sigma", "mu", "rank")
SOBOL_COLUMNS: tuple[str, ...] = ("parameter", "S1", "S1_low", "S1_high", "ST", "ST_low", "ST_high", "noise_share",
                                   "rank")


@dataclass(frozen=True, eq=False)
class Indices:
    """Sensitivity indices of every factor, one array per column (:data:`MORRIS_COLUMNS` or
    :data:`SOBOL_COLUMNS`), rows ranked (rank 1 = the largest index).

    Arrays, not a table: ``pandas.DataFrame(indices.as_dict())`` is the table a caller above builds.
    """

    data: Mapping[str, np.ndarray]

    def __getitem__(self, column: str) -> np.ndarray:
        return self.data[column]

    @property
    def columns(self) -> tuple[str, ...]:
        return tuple(self.data)

    def as_dict(self) -> dict[str, np.ndarray]:
        """Column -> its array (copies), in column order."""
        return {c: np.array(v, copy=True) for c, v in self.data.items()}


def _salib_seed(seed: int) -> int:
    """A positive int for SALib's bootstrap (SALib falls back to numpy's global state on 0/None)."""
    return int(np.random.SeedSequence(int(seed)).generate_state(1, np.uint32)[0]) | 1


def _check_y(y, n: int, what: str) -> np.ndarray:
    y = np.asarray(y, dtype=float).reshape(-1)
    if y.size != n:
        raise ResultsError(f"{what}: {y.size} response values for {n} design points")
    bad = ~np.isfinite(y)
    if bad.any():
        raise ResultsError(f"{what}: {int(bad.sum())} of {n} design points have no response value (every case's "
                           f"repetitions failed); the estimator needs every point")
    return y


def _problem(factors: Sequence[str]) -> dict:
    return {"num_vars": len(factors), "names": list(factors), "bounds": [[0.0, 1.0]] * len(factors)}


def morris_indices(unit: np.ndarray, y, *, factors: Sequence[str], levels: int, seed: int,
                   resamples: int = 1000, conf: float = 0.95) -> Indices:
    """Morris' ``mu*`` (with bootstrap interval), ``sigma`` and ``mu`` of every factor.

    Parameters
    ----------
    unit : ndarray, shape (r (d + 1), d)
        The Morris design's unit points (:attr:`faultlab.space.design.Design.unit`).
    y : array, shape (r (d + 1),)
        Response at every point.
    factors : sequence of str
    levels : int
        The design's grid levels.
    seed : int
        Seeds SALib's bootstrap.
    resamples, conf : int, float
        Bootstrap replicates and confidence level.

    Returns
    -------
    Indices
        :data:`MORRIS_COLUMNS`, sorted by ``mu*`` (rank 1 = largest); the interval is
        ``mu* -/+`` SALib's half-width, clipped at 0; NaN where every elementary effect is 0.
    """
    from SALib.analyze import morris

    unit = np.asarray(unit, dtype=float)
    y = _check_y(y, unit.shape[0], "morris_indices")
    res = morris.analyze(_problem(factors), unit, y, num_resamples=int(resamples), conf_level=float(conf),
                         num_levels=int(levels), seed=_salib_seed(seed))
    mu_star = np.asarray(res["mu_star"], dtype=float)
    half = np.asarray(res["mu_star_conf"], dtype=float)
    # every elementary effect exactly 0: the bootstrap has nothing to resample, so no interval (NaN)
    none = (mu_star == 0) & (half == 0)
    return _ranked({"parameter": np.asarray(list(factors), dtype=object), "mu_star": mu_star,
                    "mu_star_low": np.where(none, np.nan, np.maximum(mu_star - half, 0.0)),
                    "mu_star_high": np.where(none, np.nan, mu_star + half),
                    "sigma": np.asarray(res["sigma"], dtype=float), "mu": np.asarray(res["mu"], dtype=float)},
                   "mu_star")


def sobol_indices(y, *, factors: Sequence[str], seed: int, resamples: int = 1000,
                  conf: float = 0.95, noise_var: float | None = None) -> Indices:
    """First-order and total Sobol indices of every factor, with bootstrap intervals.

    Parameters
    ----------
    y : array, shape (N (d + 2),)
        Response at every point of a Saltelli design without second order
        (:func:`faultlab.space.design.sobol_design`).
    factors : sequence of str
    seed : int
        Seeds SALib's bootstrap.
    noise_var : float, optional
        Variance of the evaluation noise of one design point (for a case mean over ``K``
        repetitions, the mean of the squared standard errors).  Independent noise adds
        ``noise_var`` to the response variance ``V`` and, in the total-index estimator (half the mean
        squared difference of two evaluations), ``noise_var / V`` to every ``ST``; given it, the
        indices are those of the noise-free response: ``ST' = (ST V - noise_var) / (V - noise_var)``,
        ``S1' = S1 V / (V - noise_var)`` and the half-widths scaled by ``V / (V - noise_var)``.

    Returns
    -------
    Indices
        :data:`SOBOL_COLUMNS`, sorted by ``ST`` (rank 1 = largest); intervals are the index
        ``-/+`` SALib's half-width (not clipped: an interval reaching below 0 says the index is
        indistinguishable from 0).  ``noise_share`` is ``noise_var / V`` (0 when not given).

    Raises
    ------
    ResultsError
        A missing response value, a wrong number of values, or a constant response.
    """
    from SALib.analyze import sobol

    d = len(factors)
    y = np.asarray(y, dtype=float).reshape(-1)
    if y.size % (d + 2):
        raise ResultsError(f"sobol_indices: {y.size} response values is not a multiple of d + 2 = {d + 2}")
    y = _check_y(y, y.size, "sobol_indices")
    if not np.ptp(y) > 0:
        raise ResultsError("sobol_indices: the response is constant over the design (no variance to apportion)")
    blocks = y.reshape(-1, d + 2)
    if not np.ptp(np.concatenate([blocks[:, 0], blocks[:, -1]])) > 0:
        raise ResultsError("sobol_indices: the response is constant over the design's base samples A and B (it "
                           "varies only at a few mixed points): no variance to apportion")
    with warnings.catch_warnings():  # SALib warns of constant blocks; a constant response is refused above
        warnings.simplefilter("ignore", UserWarning)
        res = sobol.analyze(_problem(factors), y, calc_second_order=False, num_resamples=int(resamples),
                            conf_level=float(conf), seed=_salib_seed(seed))
    s1, s1c = np.asarray(res["S1"], dtype=float), np.asarray(res["S1_conf"], dtype=float)
    st, stc = np.asarray(res["ST"], dtype=float), np.asarray(res["ST_conf"], dtype=float)
    var = float(np.var(y, ddof=1))
    share = 0.0 if noise_var is None or not np.isfinite(noise_var) else float(noise_var) / var
    if share >= 1.0:
        raise ResultsError(f"sobol_indices: the noise variance ({noise_var:.3g}) is at least the response's variance "
                           f"over the design ({var:.3g}): the design cannot tell any parameter from noise")
    if share > 0:
        scale = 1.0 / (1.0 - share)
        st, stc, s1, s1c = (st - share) * scale, stc * scale, s1 * scale, s1c * scale
    s1c = np.where(s1c > 0, s1c, np.nan)  # a zero-width interval from a finite sample is no interval
    stc = np.where(stc > 0, stc, np.nan)
    return _ranked({"parameter": np.asarray(list(factors), dtype=object), "S1": s1, "S1_low": s1 - s1c,
                    "S1_high": s1 + s1c, "ST": st, "ST_low": st - stc, "ST_high": st + stc,
                    "noise_share": np.full(d, share)}, "ST")


def _descending(x: np.ndarray) -> np.ndarray:
    """Indices sorting ``x`` from largest to smallest, ties in their order, NaN last."""
    return np.argsort(-np.asarray(x, dtype=float), kind="stable")


def _ranked(columns: dict[str, np.ndarray], by: str) -> Indices:
    order = _descending(columns[by])
    ranked = {c: np.asarray(v)[order] for c, v in columns.items()}
    ranked["rank"] = np.arange(1, order.size + 1)
    return Indices(ranked)


def screen(morris: Sequence[Indices], *, keep: int) -> tuple[str, ...]:
    """The parameters screening keeps: the union over responses of the ``keep`` largest ``mu*``.

    Each response is screened on its own (a parameter that matters for one fault's effect only is
    kept); ``mu*`` is compared only within a response (its units are the response's).

    Returns
    -------
    tuple of str
        In the order of the first table's parameters.
    """
    if keep < 1:
        raise ResultsError(f"screen: keep must be >= 1, got {keep}")
    kept: set[str] = set()
    for t in morris:
        kept.update(t["parameter"][_descending(t["mu_star"])][:keep])
    order = list(morris[0]["parameter"]) if morris else []
    return tuple(sorted(kept, key=lambda p: order.index(p) if p in order else len(order)))


def noise_floor(value, std_err) -> float:
    """Share of a response's variance over cases that is repetition noise: ``mean(se^2) / Var(value)``.

    NaN if the standard errors are unknown (``K = 1``) or the response does not vary.
    """
    v = np.asarray(value, dtype=float)
    se = np.asarray(std_err, dtype=float)
    ok = np.isfinite(v) & np.isfinite(se)
    if ok.sum() < 2:
        return float("nan")
    var = float(np.var(v[ok], ddof=1))
    return float(np.mean(se[ok] ** 2) / var) if var > 0 else float("nan")
