import numpy as np
import pytest
from matplotlib.colors import to_rgba
from matplotlib.figure import Figure

from faultlab.report.casefig import LANDMARK_COLOR, PATH_COLOR, case_title, plot_case, plot_suite, save_case_png
from faultlab.scenario import generate_scenario
from faultlab.space import FIXED_VALUES, CaseSpec


@pytest.fixture(scope="module")
def scenario():
    case = CaseSpec(dict(FIXED_VALUES, map_size=25.0, inactivity=10))
    return generate_scenario(case, rng=np.random.default_rng(0), n_steps=50)


def test_plot_case_draws_landmarks_orange_and_true_path_blue(scenario):
    ax = plot_case(scenario)
    (dots,) = ax.collections
    np.testing.assert_array_equal(dots.get_offsets(), scenario.landmarks)
    np.testing.assert_allclose(dots.get_facecolor()[0], to_rgba(LANDMARK_COLOR))
    path = ax.lines[0]
    np.testing.assert_array_equal(path.get_xdata(), scenario.true_poses[:, 0])
    np.testing.assert_array_equal(path.get_ydata(), scenario.true_poses[:, 1])
    assert to_rgba(path.get_color()) == to_rgba(PATH_COLOR)
    assert LANDMARK_COLOR == "tab:orange" and PATH_COLOR == "tab:blue"
    lo, hi = ax.get_xlim()
    assert lo <= -2.5 and hi >= 2.5  # the whole 5 m x 5 m map is shown
    assert ax.get_title() == case_title(scenario) == "random, 5.0 m, 125 lm, 50 steps + 10 idle"


def test_plot_case_on_given_axes_with_title(scenario):
    ax = Figure().add_subplot()
    assert plot_case(scenario, ax, title="Case 1") is ax
    assert ax.get_title() == "Case 1"


def test_save_case_png(tmp_path, scenario):
    p = save_case_png(scenario, tmp_path / "pics" / "case1.png")
    assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_plot_suite_one_panel_per_case(scenario):
    fig = plot_suite([scenario, scenario, scenario], title="systematic")
    axes = fig.get_axes()
    assert len(axes) == 3
    assert [a.get_title() for a in axes] == ["Case 1", "Case 2", "Case 3"]
    assert fig._suptitle.get_text() == "systematic"
