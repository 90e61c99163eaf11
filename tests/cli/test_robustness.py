"""``faultlab robustness``: the verbs parse, a report of nothing is refused and writes nothing."""

import pytest

from faultlab.cli import main


def test_report_without_stores_is_one_clear_error_and_writes_nothing(tmp_path, capsys):
    out = tmp_path / "reports"
    assert main(["robustness", "report", str(tmp_path), "--reports", str(out)]) != 0
    err = capsys.readouterr().err
    assert "no store of a robustness campaign" in err and "Traceback" not in err
    assert not out.exists()


def test_run_refuses_an_unknown_slam_label(tmp_path, capsys):
    assert main(["robustness", "run", "--out", str(tmp_path / "s"), "--only", "nope"]) != 0
    assert "unknown SLAM label" in capsys.readouterr().err
    assert not (tmp_path / "s").exists()


@pytest.mark.parametrize("verb", ["run", "report"])
def test_help_ends_with_examples(verb, capsys):
    with pytest.raises(SystemExit):
        main(["robustness", verb, "--help"])
    assert "faultlab robustness" in capsys.readouterr().out.split("examples:")[1]
