import tomllib

import numpy as np
import pandas as pd
import pytest

from faultlab.cli import main
from faultlab.runner import parse_experiment, prepare_cases
from faultlab.scenario import load_scenario
from faultlab.scenario.suite import draw_suite, generate_case
from faultlab.space import table1_space


def test_generate_writes_cases_pictures_and_prints_coverage(tmp_path, capsys):
    out = tmp_path / "cases"
    assert main(["generate", "--suite", "systematic", "--seed", "7", "--out", str(out), "--steps", "30"]) == 0
    for i in range(1, 6):
        assert (out / f"case{i}.npz").exists() and (out / f"case{i}.json").exists()
        assert (out / f"case{i}.png").read_bytes()[:4] == b"\x89PNG"
    assert (out / "coverage.csv").exists() and (out / "cases.csv").exists()
    printed = capsys.readouterr().out
    assert "5 cases written" in printed
    lines = [ln.split() for ln in printed.splitlines()]
    overall = next(ln for ln in lines if ln and ln[0] == "overall")
    assert overall[1:5] == ["32", "32", "100", "%"]
    assert any(ln and ln[0] == "bias" for ln in lines)
    assert load_scenario(out / "case1").n_steps >= 30


def test_generate_is_deterministic_and_respects_options(tmp_path, capsys):
    a, b = tmp_path / "a", tmp_path / "b"
    for d in (a, b):
        assert main(["generate", "--suite", "random", "--seed", "3", "--out", str(d), "--cases", "2",
                     "--steps", "20"]) == 0
    assert sorted(p.name for p in a.glob("case*.npz")) == ["case1.npz", "case2.npz"]
    assert (a / "case2.npz").read_bytes() == (b / "case2.npz").read_bytes()
    sc = load_scenario(a / "case1")
    assert np.count_nonzero(np.any(sc.controls != 0, axis=1)) == 20


def test_malformed_space_file_fails_cleanly_and_generates_nothing(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text("[map_size]\nclasses = { small = [20, 16] }\n")
    out = tmp_path / "never"
    assert main(["generate", "--seed", "1", "--out", str(out), "--space", str(bad)]) == 1
    err = capsys.readouterr().err
    assert f"{bad}: [map_size].classes.small: lower bound 20 > upper bound 16" in err
    assert err.count("\n") == 1 and not out.exists()


def test_space_file_is_used(tmp_path, capsys):
    f = tmp_path / "two.toml"
    f.write_text('[bias.classes]\nnone = { distance = 0, angle = 0 }\npos = { distance = [0, 5], angle = [0, 0.01] }\n')
    out = tmp_path / "c"
    assert main(["generate", "--seed", "2", "--out", str(out), "--space", str(f), "--steps", "10"]) == 0
    assert sorted(p.name for p in out.glob("*.png")) == ["case1.png", "case2.png", "case3.png"]
    assert "pos=" in capsys.readouterr().out


def test_too_few_systematic_cases(tmp_path, capsys):
    assert main(["generate", "--out", str(tmp_path / "x"), "--cases", "3"]) == 1
    assert "at least 5 cases" in capsys.readouterr().err


def test_generate_writes_exactly_the_cases_a_campaign_with_the_same_seed_runs(tmp_path):
    # one case pipeline, one seed scheme: run 2's random suite of a campaign with seed 41
    exp = parse_experiment({"seed": 41, "runs": 2, "n_steps": 25, "suites": {"random": 2, "systematic": 5},
                            "slam": {"name": "dead_reckoning"}})
    infos = prepare_cases(exp, tmp_path / "campaign")
    out = tmp_path / "generated"
    assert main(["generate", "--suite", "random", "--seed", "41", "--run", "2", "--cases", "2",
                 "--steps", "25", "--out", str(out)]) == 0
    campaign = {i.case: i.path for i in infos if i.run == 2 and i.suite == "random"}
    assert sorted(campaign) == [1, 2]
    for case, path in campaign.items():
        assert (out / f"case{case}.npz").read_bytes() == path.read_bytes()
        assert (out / f"case{case}.json").read_bytes() == path.with_suffix(".json").read_bytes()
    # another run draws other cases
    other = tmp_path / "run1"
    assert main(["generate", "--suite", "random", "--seed", "41", "--run", "1", "--cases", "2",
                 "--steps", "25", "--out", str(other)]) == 0
    assert (other / "case1.npz").read_bytes() != (out / "case1.npz").read_bytes()


# Table I with only map size and landmark density varied, and a test-only constraint (Table I has
# none): keeps the suites small so that every case can be generated and drawn quickly.
SMALL_SPACE = """
[directionality]
classes = ["random"]
[rotation_error]
classes = { none = [0] }
[inactivity]
classes = { none = [0] }
[step_size]
classes = { medium = [50, 100] }
[symmetry]
classes = { low = [0, 10] }
[outlier_probability]
classes = { low = [0, 5] }
[field_of_view]
classes = { large = ["pi", "2pi"] }
[variance.classes]
low = { distance = [0, 20], angle = [0, 0.04] }
[bias.classes]
none = { distance = 0, angle = 0 }
"""
CONSTRAINTS = '[constraints]\nforbid = [{ map_size = "small", landmark_density = "low" }]\n'


def _overall(printed):
    return next(ln.split() for ln in printed.splitlines() if ln.split()[:1] == ["overall"])


def test_generate_pairwise_and_base_choice_print_their_coverage(tmp_path, capsys):
    space = tmp_path / "small.toml"
    space.write_text(SMALL_SPACE)
    out = tmp_path / "pw"
    assert main(["generate", "--suite", "pairwise", "--seed", "4", "--out", str(out), "--space", str(space),
                 "--steps", "10"]) == 0
    printed = capsys.readouterr().out
    assert len(list(out.glob("case*.npz"))) == 9  # 3 map sizes x 3 densities
    # 9 map size x density pairs, 6 x 9 pairs with a one-class parameter, 36 among those
    assert "pairwise coverage: 100 % (99 of 99 class pairs)" in printed
    assert _overall(printed)[1:5] == ["15", "15", "100", "%"]  # 9 one-class parameters + 3 + 3
    out = tmp_path / "bc"
    assert main(["generate", "--suite", "base-choice", "--seed", "4", "--out", str(out), "--space", str(space),
                 "--steps", "10", "--base", "map_size=large"]) == 0
    printed = capsys.readouterr().out
    assert len(list(out.glob("case*.npz"))) == 5  # the base case and 2 + 2 variations
    assert "base-choice coverage: 100 % (4 of 4 one-parameter variations of the base case; base case present)" \
        in printed
    # of the 9 map size x density pairs only large x (3 densities), small x medium and medium x
    # medium occur; every other pair does
    assert "pairwise coverage: 96 % (95 of 99 class pairs)" in printed
    cases = pd.read_csv(out / "cases.csv")
    assert cases["class_map_size"].iloc[0] == 2  # the base case has the --base class


def test_generate_sizes_and_weights(tmp_path, capsys):
    space = tmp_path / "small.toml"
    space.write_text(SMALL_SPACE + CONSTRAINTS)
    assert main(["generate", "--suite", "pairwise", "--out", str(tmp_path / "x"), "--space", str(space),
                 "--cases", "7"]) == 1
    assert "a pairwise suite needs at least 8 cases" in capsys.readouterr().err  # 9 pairs, 1 forbidden
    assert main(["generate", "--suite", "effect-guided", "--out", str(tmp_path / "y"), "--space", str(space)]) == 1
    assert "an effect-guided suite needs class weights" in capsys.readouterr().err
    weights = tmp_path / "w.csv"
    weights.write_text("parameter,class,weight\nlandmark_density,low,0\nlandmark_density,medium,0\n"
                       "landmark_density,high,1\n")
    out = tmp_path / "eg"
    assert main(["generate", "--suite", "effect-guided", "--out", str(out), "--space", str(space), "--cases", "6",
                 "--weights", str(weights), "--steps", "10"]) == 0
    cases = pd.read_csv(out / "cases.csv")
    # each-choice for the first 3 cases, then only the class with weight
    assert sorted(cases["class_landmark_density"].iloc[:3]) == [0, 1, 2]
    assert list(cases["class_landmark_density"].iloc[3:]) == [2, 2, 2]
    assert not ((cases["class_map_size"] == 0) & (cases["class_landmark_density"] == 0)).any()
    weights.write_text("parameter,class,weight\nlandmark_density,rare,1\n")
    assert main(["generate", "--suite", "effect-guided", "--out", str(tmp_path / "z"), "--weights", str(weights)]) == 1
    assert f"{weights}: landmark_density.rare: unknown class" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["generate", "--suite", "base-choice", "--out", str(tmp_path / "z"), "--base", "map_size"])


def test_generate_writes_the_pairwise_cases_a_campaign_with_constraints_runs(tmp_path):
    space = tmp_path / "small.toml"
    space.write_text(SMALL_SPACE + CONSTRAINTS)
    exp = parse_experiment({"seed": 12, "runs": 1, "n_steps": 15, "suites": {"pairwise": "auto", "base-choice": 5},
                            "slam": {"name": "dead_reckoning"}, "space": tomllib.loads(space.read_text())})
    infos = prepare_cases(exp, tmp_path / "campaign")
    out = tmp_path / "generated"
    assert main(["generate", "--suite", "pairwise", "--seed", "12", "--steps", "15", "--space", str(space),
                 "--out", str(out)]) == 0
    campaign = {i.case: i.path for i in infos if i.suite == "pairwise"}
    assert sorted(campaign) == list(range(1, 9))
    for case, path in campaign.items():
        assert (out / f"case{case}.npz").read_bytes() == path.read_bytes()


def test_generate_fov_bug_writes_the_defective_cases_a_campaign_would(tmp_path, capsys):
    assert main(["generate", "--suite", "fixed", "--seed", "4", "--out", str(tmp_path / "bug"), "--cases", "1",
                 "--steps", "20", "--fov-bug"]) == 0
    assert main(["generate", "--suite", "fixed", "--seed", "4", "--out", str(tmp_path / "ok"), "--cases", "1",
                 "--steps", "20"]) == 0
    bug, ok = load_scenario(tmp_path / "bug" / "case1"), load_scenario(tmp_path / "ok" / "case1")
    assert bug.meta["config"]["fov_bug"] is True and ok.meta["config"]["fov_bug"] is False
    case = draw_suite("fixed", table1_space(), root_seed=4, n_cases=1)[0]
    direct = generate_case(case, n_steps=20, fov_bug=True)
    np.testing.assert_array_equal(bug.obs_bearing, direct.obs_bearing)
    # fixed suite, opening pi: with the defect the whole right side is visible, more than without
    assert bug.obs_bearing.size > ok.obs_bearing.size
