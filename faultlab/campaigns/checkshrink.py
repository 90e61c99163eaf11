"""Reducing a case that ``faultlab check`` failed, and writing its reproducer.

For each oracle that failed a case, :func:`reduce_failure` reduces the case with
:func:`faultlab.oracles.shrink.reduce_scenario` ("still fails" = that oracle alone fails the reduced
case, judged with the case's seeds at the level it was judged at; the minimal case confirmed with
fresh seeds) and writes ``out/reproducers/<case>-<oracle>/``:

* ``case.npz`` + ``case.json``: the minimal case in the scenario format (``faultlab export`` turns it
  into a ROS 2 bag, TUM or JSON lines);
* ``replay.txt``: the one-line command that judges it again;
* ``test_<case>_<oracle>.py``: a pytest file that judges it through the adapter and asserts the oracle
  passes: it fails on the SLAM as checked and passes once the bug is fixed (``FAULTLAB_SLAM`` or
  ``FAULTLAB_COMMAND`` names another build of the SLAM to replay it on, e.g. a fixed twin).
"""

from __future__ import annotations

import json
import shlex
import string
from dataclasses import replace
from pathlib import Path

from faultlab.campaigns.checkspec import executor, reference_factory, slam_factory, use_paths
from faultlab.oracles import DEFAULT_OPTIONS, CaseJudgement, get_oracle, judge_case, repetition_seeds
from faultlab.oracles.shrink import reduce_scenario
from faultlab.scenario.model import Scenario, save_scenario

__all__ = ["reduce_failure", "replay_command", "PYTEST_TEMPLATE"]

#: The generated pytest file (``string.Template``).
PYTEST_TEMPLATE = string.Template('''\
"""Reproducer written by faultlab check: ${oracle} fails ${case_id} (minimal: ${steps} steps, ${landmarks} landmarks).

Replays the case through the SLAM's adapter and asserts the oracle passes: this test fails while the
bug is there.  Set FAULTLAB_SLAM to another SLAM (built-in name or package.module:factory), or
FAULTLAB_COMMAND to another process SLAM command, to replay it on another build, e.g. the fixed one.
"""

import json
import os
import shlex
from pathlib import Path

from faultlab.campaigns.checkspec import CheckSpec, judge_scenario
from faultlab.scenario.model import load_scenario

HERE = Path(__file__).resolve().parent
SPEC = json.loads(${spec_json})


def test_${name}():
    spec = dict(SPEC)
    if os.environ.get("FAULTLAB_SLAM"):
        spec["slam"], spec["command"] = os.environ["FAULTLAB_SLAM"], ()
    if os.environ.get("FAULTLAB_COMMAND"):
        spec["slam"], spec["command"] = "", shlex.split(os.environ["FAULTLAB_COMMAND"])
    spec["paths"] = tuple(spec["paths"]) + (str(HERE),)
    check = CheckSpec(**{**spec, "command": tuple(spec["command"]), "oracles": tuple(spec["oracles"])})
    judgement = judge_scenario(check, ${case_id_repr}, load_scenario(HERE / "case.npz"))
    (result,) = [r for r in judgement.results if r.oracle == ${oracle_repr}]
    assert result.status != "fail", result.message
''')


def _spec_for(spec, oracle: str, judgement: CaseJudgement):
    """The spec that judges by ``oracle`` alone at the per-test level the case was judged at."""
    one = replace(spec, oracles=(oracle,))
    n = max(1, get_oracle(oracle).tests({**dict(spec.options)}))
    return replace(one, alpha=min(0.5, judgement.alpha_per_test * n))


def replay_command(spec, case_file: Path, case_id: str) -> str:
    """The one-line ``faultlab check`` command that judges ``case_file`` again."""
    argv = ["faultlab", "check"]
    argv += ["--command", shlex.join(spec.command)] if spec.command else [spec.slam]
    argv += ["--case", str(case_file), "--case-id", case_id, "--oracles", *spec.oracles,
             "--seed", str(spec.seed), "--repetitions", str(spec.repetitions), "--alpha", f"{spec.alpha:g}",
             "--reference", spec.reference or "none", "--timeout", f"{spec.timeout_s:g}"]
    for p in spec.paths:
        argv += ["--path", p]
    for key, value in dict(spec.options).items():
        if key == "budget_classes":
            for cls, mm in dict(value).items():
                argv += ["--budget", f"{cls}={mm}"]
        elif key != "relations":
            argv += ["--option", f"{key}={value}"]
    if "relations" in spec.options:
        argv += ["--relations", *spec.options["relations"]]
    return shlex.join(argv)


def reduce_failure(spec, case_id: str, scenario: Scenario, judgement: CaseJudgement, out: Path,
                   classes=None) -> dict:
    """Reduce the case for every failed oracle and write the reproducers; a JSON-friendly summary.

    ``classes`` (the case's Table I classes, for per-class budgets) is kept in the minimal case's
    ``meta["check_classes"]``, where a replay finds it."""
    summary = {}
    for result in judgement.results:
        if not result.failed:
            continue
        one = _spec_for(spec, result.oracle, judgement)
        oracle = get_oracle(result.oracle)
        options = {**DEFAULT_OPTIONS, **dict(spec.options)}

        def judged(s: Scenario, seeds) -> bool:
            with use_paths(spec.paths):
                j = judge_case(case_id, s, slam_factory(spec), oracles=[oracle], seeds=seeds, alpha=one.alpha,
                               reference=reference_factory(spec), options=options, classes=classes,
                               executor=executor(spec))
            return j.results[0].failed

        seeds = repetition_seeds(spec.seed, case_id, spec.repetitions)
        fresh = repetition_seeds(spec.seed, case_id + "/confirm", spec.repetitions)
        red = reduce_scenario(scenario, lambda s: judged(s, seeds), confirm=lambda s: judged(s, fresh))
        where = out / "reproducers" / f"{case_id}-{result.oracle}"
        where.mkdir(parents=True, exist_ok=True)
        minimal = replace(red.scenario, meta={**red.scenario.meta, "check_case": case_id,
                                              **({"check_classes": dict(classes)} if classes else {})})
        case_file = save_scenario(minimal, where / "case.npz")
        command = replay_command(one, case_file, case_id)
        (where / "replay.txt").write_text(command + "\n")
        name = f"{case_id}_{result.oracle}".replace("-", "_")
        (where / f"test_{name}.py").write_text(PYTEST_TEMPLATE.substitute(
            oracle=result.oracle, case_id=case_id, steps=red.minimal["steps"], landmarks=red.minimal["landmarks"],
            spec_json=repr(json.dumps(one.to_dict())), name=name, case_id_repr=repr(case_id),
            oracle_repr=repr(result.oracle)))
        summary[result.oracle] = {"original": red.original, "minimal": red.minimal, "tests": red.tests,
                                  "confirmed": red.confirmed, "directory": str(where), "replay": command,
                                  "log": red.log}
    return summary
