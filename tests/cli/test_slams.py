"""``python -m faultlab slams`` lists every built-in SLAM with its units and applicable faults."""

import importlib.util

from faultlab.cli import main
from faultlab.faults import applicable_faults, builtin_faults
from faultlab.slam.registry import BUILTIN_SLAMS


def _row(out: str, name: str) -> list[str]:
    return next(line.split() for line in out.splitlines() if line.split()[:1] == [name])


def test_slams_lists_name_units_applicable_faults_and_description(capsys):
    assert main(["slams"]) == 0
    out = capsys.readouterr().out
    n = len(builtin_faults())
    for name, kind in BUILTIN_SLAMS.items():
        row = _row(out, name)
        assert row[1] == str(len(kind.units))
        assert row[2] == f"{len(applicable_faults(name, builtin_faults().values()).applicable)}/{n}"
        assert kind.description in out
    assert _row(out, "fastslam")[1:3] == ["16", f"{n}/{n}"]  # every built-in fault targets FastSLAM 1.0
    assert _row(out, "dead_reckoning")[1:3] == ["0", f"0/{n}"]
    assert _row(out, "ekf")[2] != f"{n}/{n}"  # EKF-SLAM has no resampling, no particle weights
    installed = importlib.util.find_spec("gtsam") is not None
    assert _row(out, "gtsam")[3] == ("yes" if installed else "no")
    assert ("gtsam: installed (" in out) == installed


def test_slams_says_how_to_install_a_missing_optional_dependency(capsys, monkeypatch):
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "gtsam" else real(name, *a))
    assert main(["slams"]) == 0
    out = capsys.readouterr().out
    assert _row(out, "gtsam")[3] == "no"
    assert "gtsam: not installed: pip install 'faultlab[gtsam]' to use SLAM 'gtsam'" in out
