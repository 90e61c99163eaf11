"""The consistency oracle: is the covariance a SLAM reports as large as its actual error?

A SLAM that reports the covariance ``P`` of its final state (:attr:`Estimate.covariance
<faultlab.slam.protocol.Estimate>`) claims that its error ``e`` (the estimate minus the truth: the
final pose, heading wrapped, and every mapped landmark of the ground truth) is distributed as
``N(0, P)``.  The normalized estimation error squared, ``NEES = e^T P^-1 e`` (Bar-Shalom, Li and
Kirubarajan 2001, Sec. 5.4), is then chi-square with ``d = 3 + 2m`` degrees of freedom (``m``
landmarks judged).  Estimate and truth share the frame of the known start pose, so no alignment is
made.

The test (one-sided, overconfidence): the case fails when the NEES exceeds the ``1 - alpha``
quantile of chi-square(d): the SLAM's error is larger than its covariance allows, the mark of a
filter that trusts its measurements or its linearisation too much, or of a covariance update with
a bug.  A covariance that is too large is conservative and passes.  A deterministic SLAM is judged on
its one run.  A stochastic SLAM's ``K`` runs share the case's measurements, so their NEES values are
not independent: each is judged at ``alpha / K`` and the case fails when any exceeds its bound
(Bonferroni, valid under any dependence).  Particle filters are overconfident by construction (their
particles collapse; Bailey, Nieto, Guivant, Stevens and Nebot 2006), so for a stochastic SLAM the
verdict is reported in the message and the case passes, unless the option ``consistency_stochastic``
is 1.  Cannot judge ("skip"): no covariance, no ground truth, or a covariance that is singular on the
judged coordinates.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.linalg import cho_factor, cho_solve
from scipy.stats import chi2

from faultlab.oracles.oracle import FAIL, PASS, SKIP, CaseRuns, Oracle, OracleResult
from faultlab.scenario.model import Scenario
from faultlab.slam.protocol import Estimate

__all__ = ["nees", "ConsistencyOracle"]


def nees(scenario: Scenario, estimate: Estimate) -> tuple[float, int]:
    """``(NEES, degrees of freedom)`` of an estimate with a covariance on a scenario with ground truth.

    The judged coordinates are the final pose and the mapped landmarks the truth has.  Raises
    ValueError when the covariance is missing or singular on them, or the scenario has no truth.
    """
    if estimate.covariance is None:
        raise ValueError("the SLAM reports no covariance")
    if not scenario.has_truth:
        raise ValueError("the scenario has no ground truth")
    truth_pose = scenario.true_poses[-1]
    e_pose = np.asarray(estimate.pose, dtype=float) - truth_pose
    e_pose[2] = (e_pose[2] + np.pi) % (2.0 * np.pi) - np.pi
    ids = np.asarray(estimate.landmark_ids)
    truth_ids = np.asarray(scenario.landmark_ids)
    common, est_at, truth_at = np.intersect1d(ids, truth_ids, return_indices=True)
    e_lm = np.asarray(estimate.landmarks, dtype=float)[est_at] - np.asarray(scenario.landmarks, dtype=float)[truth_at]
    e = np.concatenate([e_pose, e_lm.ravel()])
    rows = np.concatenate([np.arange(3), (3 + 2 * est_at[:, None] + np.arange(2)).ravel()])
    cov = np.asarray(estimate.covariance, dtype=float)[np.ix_(rows, rows)]
    try:
        factor = cho_factor(cov)
    except np.linalg.LinAlgError:
        raise ValueError("the covariance is singular on the judged coordinates") from None
    value = float(e @ cho_solve(factor, e))
    if not math.isfinite(value):
        raise ValueError("the covariance is singular on the judged coordinates")
    return value, int(e.size)


class ConsistencyOracle(Oracle):
    """The reported covariance covers the actual error (NEES against chi-square; module docstring)."""

    name = "consistency"
    description = ("the error is not larger than the SLAM's reported covariance allows (NEES against the chi-square "
                   "bound); cannot judge without a covariance or ground truth")

    def judge(self, runs: CaseRuns, *, alpha: float) -> OracleResult:
        reps = list(runs.reps)
        values, dofs, why = [], [], ""
        for k in reps:
            out = runs.run(k)
            if not out.ok:
                continue
            try:
                v, d = nees(runs.scenario, out.estimate)
            except ValueError as exc:
                why = str(exc)
                continue
            values.append(v)
            dofs.append(d)
        if not values:
            return OracleResult(self.name, runs.case_id, SKIP, f"cannot judge: {why or 'no run finished'}")
        level = alpha / len(values)
        bounds = [float(chi2.ppf(1.0 - level, d)) for d in dofs]
        over = [v > b for v, b in zip(values, bounds)]
        worst = int(np.argmax(np.asarray(values) / np.asarray(bounds)))
        p = min(float(chi2.sf(v, d)) for v, d in zip(values, dofs))
        rule = (f"one-sided chi-square test at {level:.3g}" + (f" (alpha / {len(values)} runs, Bonferroni)"
                                                               if len(values) > 1 else ""))
        msg = (f"NEES {values[worst]:.4g} vs bound {bounds[worst]:.4g} (chi-square, {dofs[worst]} degrees of "
               f"freedom; {sum(over)} of {len(values)} runs above); {rule}")
        details = {"nees": [round(v, 6) for v in values], "dof": dofs, "bound": [round(b, 6) for b in bounds]}
        failed = any(over)
        if failed and not runs.deterministic and not runs.options.get("consistency_stochastic", 0):
            return OracleResult(self.name, runs.case_id, PASS, "overconfident, reported not failed (a stochastic "
                                "SLAM, e.g. a particle filter, is overconfident by construction; option "
                                f"consistency_stochastic=1 fails it): {msg}", statistic=values[worst],
                                unit="NEES", p_value=p, details={**details, "overconfident": True})
        return OracleResult(self.name, runs.case_id, FAIL if failed else PASS,
                            ("overconfident: " if failed else "consistent: ") + msg, statistic=values[worst],
                            unit="NEES", p_value=p, details=details)
