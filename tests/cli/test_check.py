"""faultlab check from the installed command: a user's factory imported from the working directory
(in two workers), exit status 0/1/2, the JUnit XML and resuming."""

import os
import subprocess
import sys
from pathlib import Path

from junitparser import Failure, JUnitXml

SPACE = Path(__file__).resolve().parents[1] / "oracles" / "small_space.toml"

MODULE = '''
import numpy as np
from faultlab.slam import Estimate
from faultlab.slam.deadreckoning import DeadReckoning


class Broken(DeadReckoning):
    def estimate(self):
        est = super().estimate()
        return Estimate(est.pose, est.landmark_ids, est.landmarks * np.nan)


def make():
    return DeadReckoning()


def make_broken():
    return Broken()
'''


def _check(cwd, *args):
    command = Path(sys.executable).with_name("faultlab")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    return subprocess.run([str(command), "check", *args, "--space", str(SPACE), "--steps", "30", "--reference",
                           "none", "--oracles", "execution", "floor", "--jobs", "2"], cwd=cwd, env=env,
                          capture_output=True, text=True)


def test_check_of_a_user_factory_from_its_directory(tmp_path):
    (tmp_path / "mylab").mkdir()
    (tmp_path / "mylab" / "__init__.py").write_text("")
    (tmp_path / "mylab" / "mapper.py").write_text(MODULE)
    ok = _check(tmp_path, "mylab.mapper:make", "--out", "good")
    assert ok.returncode == 0, ok.stderr + ok.stdout
    xml = JUnitXml.fromfile(str(tmp_path / "good" / "report" / "check-junit.xml"))
    cases = [c for suite in xml for c in suite]
    assert len(cases) == 20 * 2 and not any(isinstance(r, Failure) for c in cases for r in c.result)
    again = _check(tmp_path, "mylab.mapper:make", "--out", "good")  # resumes: nothing left to run
    assert again.returncode == 0 and again.stdout == ok.stdout

    bad = _check(tmp_path, "mylab.mapper:make_broken", "--out", "bad", "--no-shrink")
    assert bad.returncode == 1
    xml = JUnitXml.fromfile(str(tmp_path / "bad" / "report" / "check-junit.xml"))
    failed = [c.name for suite in xml for c in suite if any(isinstance(r, Failure) for r in c.result)]
    assert len(failed) == 20 and all(name.endswith(" execution") for name in failed)


def test_usage_errors_exit_2_and_write_nothing(tmp_path):
    missing = _check(tmp_path, "nowhere.module:make", "--out", "x")
    assert missing.returncode == 2 and "cannot import module 'nowhere.module'" in missing.stderr
    both = _check(tmp_path, "ekf", "--command", "./slam", "--out", "x")
    assert both.returncode == 2
    assert not (tmp_path / "x").exists()
