"""faultlab.data: the shipped experiments and paper data, found by name or path from anywhere."""

from __future__ import annotations

import fnmatch
import os
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from faultlab import data
from faultlab.errors import ConfigError
from faultlab.runner import load_experiment
from faultlab.space import load_space, table1_space

REPO = Path(__file__).resolve().parents[2]
PACKAGE_DATA = REPO / "faultlab" / "data"
#: The repository's top-level folders and the package folders they link into.
LINKED = {"experiments": PACKAGE_DATA / "experiments", "paper_repro": PACKAGE_DATA / "paper"}
SHIPPED = ("effects", "mutation-paper", "mutation-rtb", "mutation-user", "mutation", "paper-k10", "paper", "robustness", "slams", "smoke", "space_table1",
           "study-confirm", "study-k", "study-large-faults", "study-large-mutants", "study-large", "study-medium", "study")  # sorted by file name: "-" < "."
_LISTED = re.escape(", ".join(SHIPPED))  # as an error message lists them


def _files(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.is_file())


def test_experiment_names_are_the_packaged_files():
    assert data.experiment_names() == SHIPPED
    assert [f"{n}.toml" for n in data.experiment_names()] == _files(PACKAGE_DATA / "experiments")


@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_names_resolve_to_the_packaged_file_from_any_directory(name, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    path = data.resolve_experiment(name)
    assert path.is_file() and path.name == f"{name}.toml"
    assert path.samefile(PACKAGE_DATA / "experiments" / f"{name}.toml")
    assert data.experiment_file(name) == path
    # the repository path of the file (as written in the README) also works outside the clone
    assert data.resolve_experiment(f"experiments/{name}.toml").samefile(path)


def test_an_existing_path_wins_over_a_shipped_name(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "paper").write_text("seed = 5\n")
    (tmp_path / "experiments").mkdir()
    (tmp_path / "experiments" / "paper.toml").write_text("seed = 6\n")
    assert data.resolve_experiment("paper") == Path("paper")
    assert data.resolve_experiment("experiments/paper.toml") == Path("experiments/paper.toml")
    assert load_experiment("paper").seed == 5 and load_experiment("experiments/paper.toml").seed == 6
    own = tmp_path / "campaign.toml"
    own.write_text("seed = 7\n")
    assert data.resolve_experiment(own) == own and load_experiment(own).seed == 7


def test_a_directory_named_like_a_shipped_experiment_does_not_hide_it(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "paper").mkdir()  # e.g. a results directory
    assert data.resolve_experiment("paper").samefile(PACKAGE_DATA / "experiments" / "paper.toml")


def test_unknown_name_is_one_error_listing_the_shipped_names(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ConfigError, match=rf"^unknown experiment file 'papr': .*\({_LISTED}\)$"):
        data.resolve_experiment("papr")
    with pytest.raises(ConfigError, match=rf"^unknown experiment 'papr'.*{_LISTED}"):
        data.experiment_file("papr")
    with pytest.raises(ConfigError, match=r"^unknown parameter-space file 'tabel1'.*space_table1"):
        load_space("tabel1")
    with pytest.raises(ConfigError, match=r"^unknown experiment file 'papr'.*paper, robustness, slams, smoke"):
        load_experiment("papr")


def test_a_missing_path_cannot_be_read_and_the_error_lists_the_shipped_names(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    for arg in ("paper.toml", "experiments/other.toml", tmp_path / "x" / "paper.toml"):
        with pytest.raises(ConfigError, match=r"experiment file cannot be read \(no such file; .*"
                                              rf"{_LISTED}\)"):
            data.resolve_experiment(arg)


def test_loading_by_name_equals_loading_the_repository_file(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    by_name = load_experiment("paper")
    by_path = load_experiment(REPO / "experiments" / "paper.toml")
    assert by_name.hash == by_path.hash and by_name.text == by_path.text
    assert by_name.source == "paper"  # the argument as given: it names the experiment anywhere
    assert load_experiment("smoke").hash == load_experiment(REPO / "experiments" / "smoke.toml").hash
    assert load_space("space_table1").parameters == table1_space().parameters


@pytest.mark.parametrize("top", sorted(LINKED))
def test_top_level_files_are_relative_links_to_the_one_packaged_copy(top):
    folder, packaged = REPO / top, LINKED[top]
    assert _files(folder) == _files(packaged)  # a link for every packaged file, nothing else
    for name in _files(folder):
        link = folder / name
        assert link.is_symlink(), f"{top}/{name} must be a link into faultlab/data"
        target = Path(os.readlink(link))
        assert not target.is_absolute()  # works in any clone
        assert link.resolve() == (packaged / name).resolve()
        assert not (packaged / name).is_symlink()
        assert link.read_bytes() == (packaged / name).read_bytes()


def test_paper_files_are_the_packaged_csvs():
    files = data.paper_files()
    assert set(files) == {"raw", "reported"}
    assert files["raw"].samefile(REPO / "paper_repro" / "paper_table2_rms.csv")
    assert files["reported"].samefile(REPO / "paper_repro" / "paper_table2_reported.csv")
    assert files["raw"].read_text().startswith("suite,variant,run,case,rms_mm")
    with pytest.raises(ConfigError, match="paper_table2_rms.csv, paper_table2_reported.csv|"
                                          "paper_table2_reported.csv, paper_table2_rms.csv"):
        data.paper_file("table3.csv")


def test_shipped_file_maps_only_repository_paths_of_shipped_files():
    assert data.shipped_file("paper_repro/paper_table2_rms.csv") == data.paper_files()["raw"]
    assert data.shipped_file(Path("experiments") / "smoke.toml") == data.experiment_file("smoke")
    for other in ("paper_repro/other.csv", "experiments/paper.csv", "reports/table2.csv",
                  "x/experiments/paper.toml", "paper.toml", str(REPO / "experiments" / "paper.toml")):
        assert data.shipped_file(other) is None, other


def test_every_packaged_data_file_is_declared_as_package_data():
    """A data file the globs miss would be absent from the wheel (the CI install check catches it too)."""
    pyproject = tomllib.loads((REPO / "pyproject.toml").read_text())
    globs = pyproject["tool"]["setuptools"]["package-data"]["faultlab.data"]
    files = [p.relative_to(PACKAGE_DATA).as_posix() for p in PACKAGE_DATA.rglob("*")
             if p.is_file() and p.suffix != ".py" and "__pycache__" not in p.parts]
    assert len(files) == 2 + len(SHIPPED) + 1  # the paper's two CSVs, the experiments and the study's weights
    for f in files:
        assert any(fnmatch.fnmatch(f, g) for g in globs), f"{f} is not package data"


def test_paper_table_runs_from_another_directory(tmp_path):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]))
    proc = subprocess.run([sys.executable, "-m", "faultlab", "paper-table"], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert "Table II recomputed from paper_repro/paper_table2_rms.csv" in proc.stdout  # the data's portable label
    assert proc.stdout.count("<-- DIFFERS") == 1
    assert "random / missing_angle_wrap: computed 73 %, printed 80 %" in proc.stdout
    assert list(tmp_path.iterdir()) == []  # reads only
