import numpy as np

from faultlab.cli import main
from faultlab.runner import parse_experiment, prepare_cases
from faultlab.scenario import load_scenario


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
