"""Faults and mutants against the reference FastSLAM on the compiled path (a benchmark, not a test).

Run ``python benchmarks/bench_faults.py`` from the repository root.  On the fixed-suite case
(``--steps`` steps of it, default all 1000; ``--particles``, default 200) it times, alternated ``--rounds`` times in
one process after a warm-up run of each (best CPU time kept, ``time.process_time``):

* the reference filter;
* a no-op replacement (``resample`` replaced by a function that calls the reference unit);
* a no-op replacement of each correction unit (a function that calls the unit's compiled twin: the
  cost of the staged correction around a replaced unit);
* every built-in fault;
* a sample of ``--mutants`` live-looking mutants (every ``len // m``-th of the generated mutants of
  all units, screened with the unit examples, stillborn and equivalent ones left out);

and prints each one's CPU time and its ratio to the reference's.  Every replaced filter is also run on
the unit-by-unit path (the partial reference step and the staged correction turned off) and its
estimate checked bit-identical.  A fault's ratio includes what the fault changes in the filter's work
(e.g. resampling at every step), not only the path's cost.
``--aliasing`` adds ``paper_aliasing`` against the reference at 20 particles (60 steps, the studies'
setting) and 200 particles.  Targets: every fault and mutant <= 1.25x the reference, the no-op
replacement <= 1.1x, ``paper_aliasing`` <= 5x.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_fastslam import truncated  # noqa: E402
from machine import describe  # noqa: E402

from faultlab.faults import builtin_faults, get_fault  # noqa: E402
from faultlab.faults.check import estimates_identical  # noqa: E402
from faultlab.mutation.examples import unit_examples  # noqa: E402
from faultlab.mutation.mutant import generate_mutants, mutant_fault  # noqa: E402
from faultlab.mutation.screening import screen_mutants  # noqa: E402
from faultlab.scenario import generate_scenario  # noqa: E402
from faultlab.slam import REFERENCE_STEPS, FastSlam, FastSlamConfig, run_slam, twins  # noqa: E402
from faultlab.slam import units as U  # noqa: E402
from faultlab.slam.fastslam import FastSlamSteps  # noqa: E402
from faultlab.space.case import FIXED_VALUES, CaseSpec  # noqa: E402


#: The correction units the staged correction runs a replacement of (each with a compiled twin).
CORRECTION_UNITS = ("predict_measurement", "innovation", "innovation_covariance", "log_likelihood", "ekf_update")


def case(steps: int, seed: int):
    """The first ``steps`` steps of the fixed-suite case."""
    sc = generate_scenario(CaseSpec(FIXED_VALUES), rng=np.random.default_rng(seed))
    return truncated(sc, steps) if steps < sc.n_steps else sc


def noop_resample(w, n_eff, empty, rng, config):
    """A replacement that changes nothing: the reference unit, called through another function."""
    return U.resample(w, n_eff, empty, rng, config)


def noop_twin(name: str):
    """A replacement of the correction unit ``name`` that changes nothing: it calls the unit's compiled
    twin (so its ratio is the cost of the staged correction around a replaced unit, not of numpy)."""

    def replaced(*args, **kwargs):
        return getattr(twins, name)(*args, **kwargs)

    return replaced


def run(make, sc, seed, *, partial=True):
    """(CPU s, estimate or the exception's repr) of one execution."""
    slam = make()
    if not partial:  # the unit-by-unit path: every stage calls its units
        slam._ref_predict = slam._ref_correct = False
        slam._stage = None
    c0 = time.process_time()
    try:
        with np.errstate(all="ignore"):
            est = run_slam(slam, sc, rng=np.random.default_rng(seed))
    except Exception as exc:  # a fault may end the run
        est = repr(exc)
    return time.process_time() - c0, est


def same(a, b) -> bool:
    return a == b if isinstance(a, str) or isinstance(b, str) else estimates_identical(a, b)


def mutant_sample(count: int, cfg, ids: list[str] | None = None):
    """About ``count`` screened-live mutants of the reference units, spread over the generated list
    (or the mutants ``ids``, to time the same sample in another run)."""
    mutants = generate_mutants(REFERENCE_STEPS, plugins=False)
    if not ids:
        report = screen_mutants(mutants, unit_examples())
        live = [i for i, r in report.results.items() if r.live]
        ids = live[::max(1, len(live) // count)][:count]
    return {f"mutant {i}": (lambda m=mutants.get(i): mutant_fault(m, FastSlamSteps).apply(FastSlam(cfg)))
            for i in ids}


def compare(makers: dict, sc, seed: int, rounds: int, check: bool) -> dict:
    """Best CPU time of each maker, alternated ``rounds`` times after one warm-up round."""
    best = {name: math.inf for name in makers}
    for r in range(rounds + 1):
        for name, make in makers.items():
            cpu, est = run(make, sc, seed)
            if r == 0:  # warm-up: first calls, caches; and the check against the unit-by-unit path
                if check and name != "reference" and not same(est, run(make, sc, seed, partial=False)[1]):
                    again = same(est, run(make, sc, seed)[1])
                    print(f"  {name}: NOT bit-identical to the unit-by-unit path"
                          + ("" if again else " (nor to itself: the replacement is not deterministic, e.g. "
                             "it reads memory no unit wrote)"))
                continue
            best[name] = min(best[name], cpu)
    return best


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--steps", type=int, default=1000)
    ap.add_argument("--mutants", type=int, default=20)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--particles", type=int, default=200)
    ap.add_argument("--mutant-ids", default="", help="comma-separated mutant ids instead of the sample")
    ap.add_argument("--aliasing", action="store_true", help="also paper_aliasing at 20 and 200 particles")
    args = ap.parse_args(argv)
    print(f"faults and mutants vs the reference, compiled path; {describe()}")
    twins.warm_up()
    sc = case(args.steps, args.seed)
    cfg = FastSlamConfig(particles=args.particles)
    makers = {"reference": lambda: FastSlam(cfg),
              "no-op replacement": lambda: FastSlam(cfg, steps=dataclasses.replace(REFERENCE_STEPS,
                                                                                   resample=noop_resample))}
    makers.update({f"no-op {name} (calls its twin)": (lambda name=name: FastSlam(cfg, steps=dataclasses.replace(
        REFERENCE_STEPS, **{name: noop_twin(name)}))) for name in CORRECTION_UNITS})
    makers.update({f.name: (lambda f=f: f.apply(FastSlam(cfg))) for f in builtin_faults().values()})
    if args.mutants:
        makers.update(mutant_sample(args.mutants, cfg, [i for i in args.mutant_ids.split(",") if i]))
    best = compare(makers, sc, args.seed, args.rounds, check=True)
    ref = best["reference"]
    print(f"\nfixed case, {sc.n_steps} steps, {args.particles} particles; CPU s, best of {args.rounds}, ratio to the reference")
    worst = {}
    for name, cpu in best.items():
        kind = "noop" if name == "no-op replacement" else "staged" if name.startswith("no-op") else "mutant" if name.startswith("mutant") else "fault"
        worst[kind] = max(worst.get(kind, 0.0), cpu / ref)
        print(f"  {name:<58} {cpu:8.3f} {cpu / ref:6.2f}x")
    replaced = [cpu for name, cpu in best.items() if name != "reference"]
    print(f"mean CPU per execution of the {len(replaced)} replaced filters: {sum(replaced) / len(replaced):.3f} s")
    print(f"worst: faults {worst.get('fault', 0):.2f}x, mutants {worst.get('mutant', 0):.2f}x (target <= 1.25x), "
          f"no-op {worst['noop']:.2f}x (target <= 1.1x), no-op correction units {worst.get('staged', 0):.2f}x")
    if args.aliasing:
        alias = get_fault("paper_aliasing")
        for n, steps in ((20, 60), (200, args.steps)):
            cfg = FastSlamConfig(particles=n)
            b = compare({"reference": lambda: FastSlam(cfg), "paper_aliasing": lambda: alias.apply(FastSlam(cfg))},
                        case(steps, args.seed), args.seed, args.rounds, check=False)
            print(f"paper_aliasing, {n} particles, {steps} steps: {b['paper_aliasing']:.3f} CPU s against "
                  f"{b['reference']:.3f}, {b['paper_aliasing'] / b['reference']:.2f}x (target <= 5x)")
    print(f"load average after: {describe().rsplit('load average ', 1)[1]}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
