"""Drawing rules of the figures (issue 13): legends list exactly what is drawn, flags are
not raised where D is exact, log axes, titles name the f-range, n and t.  Drawn from
small hand-made results, so the rules are checked without running a simulation."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
import pytest

from bbdyn.scenes import scene_module
from bbdyn.scenes.frequency_scene import D_ZERO, SCENE_KEYS, FrequencyScanScene

F = np.array([50.0, 51.0, 52.0, 53.0, 54.0])


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


def legend_texts(ax):
    return [t.get_text() for t in ax.get_legend().get_texts()]


def frequency_scene(**arrays):
    """A FrequencyScanScene on ``F`` (n = 7 particles, t = 3 s): zeros unless given."""
    base = {k: np.zeros(F.size) for k in SCENE_KEYS} | {"D_converged": np.ones(F.size),
                                                          "energy_stationary": np.ones(F.size)}
    base |= {k: np.asarray(v, dtype=float) for k, v in arrays.items()}
    tongues = np.array([[1.0, 50.5, 51.5]])
    meta = {"scan_compute": {"kwargs": {"n": 7, "t": 3.0}}}
    return FrequencyScanScene({"f": F, "tongues": tongues} | base, meta)


def b1_result():
    """Regimes a, a, d, d, d; one attractor but two at 51 Hz; unsettled only at 53 Hz."""
    from bbdyn.scenes.b1_regime_map import SceneB1Result

    fractions = np.zeros((F.size, 4))
    fractions[:, 0] = [1.0, 0.7, 1.0, 0.9, 1.0]
    fractions[1, 1] = 0.3
    arrays = {
        "f": F,
        "regime": np.array([0, 0, 4, 4, 4], dtype=float),
        "n_attractors": np.array([1, 2, 1, 1, 1], dtype=float),
        "unsettled_fraction": np.array([0, 0, 0, 0.1, 0]),
        "fractions": fractions,
    }
    return SceneB1Result(arrays, {"settings": {"n": 7, "t": 3.0}})


def test_b1_legends_list_exactly_the_drawn_regimes_and_series():
    from bbdyn.classify import REGIMES

    fig = scene_module("B1").draw(b1_result())
    ax_reg, ax_n, ax_fr = fig.axes
    assert legend_texts(ax_reg) == [f"a: {REGIMES['a']}", f"d: {REGIMES['d']}"]
    # attractors 3 and 4+ hold nothing anywhere: not drawn, not listed
    assert legend_texts(ax_fr) == ["attractor 1", "attractor 2", "unsettled"]
    assert len(ax_fr.collections) == 3
    # stacked to the top of the unsettled fraction: the whole ensemble
    top = ax_fr.collections[-1].get_paths()[0].vertices[:, 1].max()
    assert top == pytest.approx(1.0)


def test_b1_counts_attractors_on_an_integer_axis():
    fig = scene_module("B1").draw(b1_result())
    fig.canvas.draw()
    ticks = [t for t in fig.axes[1].get_yticks() if fig.axes[1].get_ylim()[0] <= t]
    assert ticks and all(float(t).is_integer() for t in ticks)


def test_s3_flags_skip_points_where_d_is_zero_to_rounding():
    scene = frequency_scene(
        D=[0.0, 1e-15, -0.2, 3.0, 2 * D_ZERO],
        D_err=[0.0, 1e-16, 0.3, 1.0, 0.0],
        D_converged=[0, 0, 0, 1, 0],
    )
    np.testing.assert_array_equal(scene.D_zero_to_rounding(), [True, True, False, False, False])
    fig = scene_module("S3").draw(scene)
    flags = [ln for ln in fig.axes[0].lines if ln.get_label().startswith("D windows disagree")]
    assert len(flags) == 1
    np.testing.assert_array_equal(flags[0].get_xdata(), [52.0, 54.0])


def test_s3_legend_explains_the_tongue_shading_and_stays_off_the_axes():
    fig = scene_module("S3").draw(frequency_scene(D=[1.0, 2.0, 3.0, 2.0, 1.0]))
    ax = fig.axes[0]
    assert "k/1 tongue of the flat ball" in legend_texts(ax)
    assert not any(t.startswith("D windows disagree") for t in legend_texts(ax))  # none flagged
    fig.canvas.draw()
    legend = ax.get_legend().get_window_extent()
    assert legend.x0 >= ax.get_window_extent().x1  # right of the data


def test_s3_regime_strip_lists_the_regimes_of_the_map():
    fig = scene_module("S3").draw(frequency_scene(), regimes=b1_result())
    assert [t.split(":")[0] for t in legend_texts(fig.axes[1])] == ["a", "d"]


@pytest.mark.parametrize("sid, key", [("S4", "E"), ("S5", "E_x")])
def test_s4_s5_mark_the_non_stationary_points(sid, key):
    scene = frequency_scene(**{key: F / 10, "energy_stationary": [1, 0, 1, 1, 0]})
    ax = scene_module(sid).draw(scene).axes[0]
    marks = [ln for ln in ax.lines if ln.get_label().startswith("energy not stationary")]
    assert len(marks) == 1
    np.testing.assert_array_equal(marks[0].get_xdata(), [51.0, 54.0])
    np.testing.assert_array_equal(marks[0].get_ydata(), [5.1, 5.4])


@pytest.mark.parametrize("sid", ["S3", "S4", "S5"])
def test_frequency_scene_titles_name_range_n_and_t(sid):
    title = scene_module(sid).draw(frequency_scene()).axes[0].get_title()
    assert "f = 50-54 Hz (5 frequencies)" in title
    assert "n = 7 particles" in title and "t = 3 s" in title


def s9_result():
    from bbdyn.scenes.s9_random_walk import SceneS9Result

    arrays = {"f": F, "gamma": np.full(F.size, 2.5)}
    for key, values in (("D", [0.0, 0.1, 2.0, 50.0, -1e-3]), ("D_rw", [0.5, 0.02, 1.0, 4.0, 4.0]),
                        ("D_a", [np.nan, 1.0, 1.5, 5.0, 6.0]), ("r", [10.0] * 5),
                        ("tau", [1.0] * 5)):  # fmt: skip
        arrays[key] = np.array(values)
        arrays[key + "_err"] = np.abs(arrays[key]) / 10
    arrays["D_rw_err"][1] = 0.05  # D_rw = 0.02 +- 0.05: zero within its error
    meta = {"f_gamma2": 50.5, "scan_manifest": {"compute": {"kwargs": {"n": 7, "t": 3.0}}}}
    return SceneS9Result(arrays, meta)


def test_s9_d_axis_is_log_and_marks_values_it_cannot_show():
    fig = scene_module("S9").draw(s9_result())
    ax = fig.axes[0]
    assert ax.get_yscale() == "log"
    assert "n = 7 particles, t = 3 s" in ax.get_title() and "f = 50-54 Hz" in ax.get_title()
    # D <= 0 at 50 and 54 Hz, D_rw within 2 errors of 0 at 51 Hz: triangles on the bottom edge
    edge = [ln for ln in ax.lines if ln.get_marker() == "v" and ln.get_xdata().size]
    assert sorted(x for ln in edge for x in ln.get_xdata()) == [50.0, 51.0, 54.0]
    # 0.1 and 2 mm^2/s are inside the visible range next to D_rw and D_a
    lo, hi = ax.get_ylim()
    assert lo < 0.1 and hi > 50.0


def test_s1_legend_names_both_edge_markers():
    from bbdyn.scenes.s1_tongues import SceneS1Result

    alpha = np.linspace(0, 1, 5)
    arrays = {"k": np.array([1, 2]), "alpha_curve": alpha,
              "gamma_lo_curve": np.array([1 + alpha, 3 + alpha]),
              "gamma_hi_curve": np.array([2 + alpha, 4 + alpha]),
              "alpha_points": alpha[1:3], "gamma_lo_numeric": np.ones((2, 2)),
              "gamma_hi_numeric": 2 * np.ones((2, 2))}  # fmt: skip
    ax = scene_module("S1").draw(SceneS1Result(arrays, {})).axes[0]
    texts = legend_texts(ax)
    assert texts[:2] == ["1/1 tongue (closed form)", "2/1 tongue (closed form)"]
    markers = {h.get_marker() for h in ax.get_legend().legend_handles if hasattr(h, "get_marker")}
    assert {"v", "^"} <= markers
    assert any("+1" in t for t in texts) and any("-1" in t for t in texts)


def test_b3_standard_errors_carry_their_sampling_error():
    from bbdyn.scans.statcost import StatCostResult

    arrays = {"f": np.array([60.0]), "n": np.array([5, 17]), "t": np.array([1.0, 2.0]),
              "cpu_n": np.array([[1.0, 2.0]]), "D_err_n": np.array([[4.0, 2.0]]),
              "cpu_t": np.array([[1.0, 2.0]]), "D_err_t": np.array([[3.0, 3.0]]),
              "slope_n": np.array([-0.5]), "slope_t": np.array([0.0])}  # fmt: skip
    meta = {"settings": {"n_fixed": 9, "t_fixed": 1.0}}
    ax = scene_module("B3").draw(StatCostResult(arrays, meta)).axes[0]
    # half-lengths D_err / sqrt(2 (n - 1)): n = 5, 17 (n grows), n = 9 (t grows)
    halves = []
    for container in ax.containers:
        segments = container.lines[2][0].get_segments()
        halves.append([abs(s[1, 1] - s[0, 1]) / 2 for s in segments])
    np.testing.assert_allclose(halves[0], [4.0 / np.sqrt(8), 2.0 / np.sqrt(32)])
    np.testing.assert_allclose(halves[1], [3.0 / 4, 3.0 / 4])
    assert "t = 1 s" in ax.get_title() and "n = 9" in ax.get_title()


def test_b2_points_are_numbered_and_named_in_words():
    import math

    from bbdyn.core.tolerances import EPS, ROOT_STEP_REL
    from bbdyn.scenes.b2_flat import FlatBenchResult

    errors = {"max_time_error_s": 1e-12, "max_velocity_error": 0.0}
    rows = [
        {"method": "exact", "setting": "default", "step_rel": ROOT_STEP_REL,
         "impacts_per_s": 1e6, **errors},
        {"method": "exact", "setting": "continuous run", "impacts_per_s": 2e6, **errors},
        {"method": "fixed_step", "setting": "dt", "dt": 1e-4, "dt_min": 1e-6,
         "impacts_per_s": 1e5, **errors},
        {"method": "solve_ivp", "setting": "ivp", "ivp_method": "RK45", "frame": "lab",
         "rtol": 1e-6, "max_step_periods": 0.05, "impacts_per_s": 1e3, **errors},
        {"method": "solve_ivp", "setting": "ivp", "ivp_method": "DOP853", "frame": "plate",
         "rtol": 1e-10, "max_step_periods": math.inf, "impacts_per_s": 1e3, **errors},
    ]  # fmt: skip
    meta = {"rows": rows, "case": {"f": 82.0, "alpha": 0.8}, "settings": {"n_impacts": 40}}
    fig = scene_module("B2-FLAT").draw(FlatBenchResult({}, meta))
    key = fig.texts[-1].get_text().splitlines()
    assert key == [
        f"1: exact, default root tolerance ({ROOT_STEP_REL / EPS:g} eps of the flight time)",
        "2: fixed step 0.0001 s, refined to 1e-06 s",
        "3: solve_ivp RK45, lab frame, rtol 1e-06, max step 0.05 periods",
        "4: solve_ivp DOP853, plate frame, rtol 1e-10",
    ]  # the continuous run is not a one-step point: not drawn, not named
    for ax in fig.axes:
        assert sorted(t.get_text() for t in ax.texts) == ["1", "2", "3", "4"]
