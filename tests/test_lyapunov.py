"""Lyapunov exponents of the flat ball through impacts and sticks (bbdyn.lyapunov, core.tangent).

Independent facts: the multipliers of periodic orbits from the Newton solver,
the closed-form determinant ``alpha vrel+ / (-vrel-)`` of the impact map (which
telescopes along a trajectory), finite differences of whole trajectories of the
event kernel, and the stick that forgets the state.
"""

import json
import math
from pathlib import Path

import numpy as np
import pytest
from json_trees import json_close

from bbdyn.core.flat import FlatArrays, FlatState, flat_run
from bbdyn.core.plate import TWO_PI
from bbdyn.core.status import IMPACT, OK, STICK, STUCK_FOREVER
from bbdyn.core.tangent import TangentWindows, flat_tangent_run
from bbdyn.flat.tongues import (
    find_periodic_orbit,
    k1_orbit_numeric,
    params_at_gamma,
    tongue_gamma_hi,
)
from bbdyn.lyapunov import flat_lyapunov, flat_lyapunov_from
from bbdyn.params import Params

ALPHA = 0.5
#: a chaotic flat ball (positive exponent, rare sticks) for the trajectory checks
CHAOTIC = Params(f=120.0, alpha=0.8)


def _run_kernel(p, phase, vrel, t_end_periods):
    """One particle from an impact with the identity frame, one window; returns the outputs."""
    frame = np.array([1.0, 0.0, 0.0, 1.0])
    log, imp, col, end = (
        np.zeros((1, 2)),
        np.zeros(1, np.int64),
        np.zeros(1, np.int64),
        np.full(1, np.nan),
    )
    out = TangentWindows(log, imp, col, end)
    start = (0.0, phase, vrel, IMPACT)
    state, status = flat_tangent_run(start, p.kernel(), np.array([t_end_periods]), frame, out)
    return (*state, status), frame, log[0], int(imp[0]), int(col[0])


def _orbit_bound(orbit, n_impacts):
    """Bound on the QR error of the exponents per impact after ``n_impacts``: the
    frame's start and end contribute at most log cond(V) each (V: eigenvectors)."""
    _, vecs = np.linalg.eig(orbit["jacobian"])
    return 2.0 * math.log(np.linalg.cond(vecs)) / n_impacts + 1e-9


def _check_orbit_exponents(p, orbit, k, m):
    res = flat_lyapunov_from(p, [orbit["phase"][0]], [orbit["vrel"][0]], t=30.0, transient=0.0)
    assert res["collapses"].sum() == 0
    n_imp = int(res["impacts"].sum())
    mu = np.sort(np.log(np.abs(orbit.eigenvalues)))[::-1] / m
    lam_imp = res.exponents("impact")[0]
    assert lam_imp == pytest.approx(mu, abs=_orbit_bound(orbit, n_imp // m))
    # per second: the orbit takes k periods for m impacts
    lam_s = res.exponents("second")[0]
    assert lam_s == pytest.approx(
        mu * m / (k / p.f),
        abs=_orbit_bound(orbit, n_imp // m) * m * p.f / k + 1e-6 * abs(mu[0]) * p.f,
    )


def test_exponents_of_a_1_1_orbit_with_real_multipliers_are_their_logs():
    gamma = tongue_gamma_hi(1, ALPHA) * 0.98  # below the flip: stable, real multipliers
    p = params_at_gamma(gamma, alpha=ALPHA)
    orbit = k1_orbit_numeric(1, gamma, ALPHA)
    assert np.all(orbit.eigenvalues.imag == 0) and orbit.is_stable
    mu = np.log(np.abs(orbit.eigenvalues))
    assert abs(mu[0] - mu[1]) > 0.5  # distinct: the test separates the two exponents
    _check_orbit_exponents(p, orbit, 1, 1)


def test_exponents_of_a_period_2_orbit_are_the_logs_of_its_multipliers_over_two():
    gamma = tongue_gamma_hi(1, ALPHA) * 1.004
    p = params_at_gamma(gamma, alpha=ALPHA)
    one = k1_orbit_numeric(1, gamma, ALPHA)
    out = (np.empty(3000), np.empty(3000), np.empty(3000), np.empty(3000, np.int64))
    start = FlatState(0.0, one["phase"][0] + 1e-4, one["vrel"][0], IMPACT)
    _, n_done, status = flat_run(start, p.kernel(), 3000, FlatArrays(*out))
    assert status == OK and n_done == 3000
    two = find_periodic_orbit(p, 2, 2, out[1][-1], out[2][-1])
    assert two.is_stable and np.all(two.eigenvalues.imag == 0)
    _check_orbit_exponents(p, two, 2, 2)


def test_sum_of_the_spectrum_is_the_closed_form_determinant_which_telescopes():
    """log|det J| = log(alpha vrel_i / (-vrel-)) = 2 log alpha + log vrel_i - log vrel_{i+1}."""
    rng = np.random.default_rng(3)
    checked = 0
    for phase, vrel in zip(TWO_PI * rng.random(6), 1.0 + 30.0 * rng.random(6), strict=True):
        (periods, phase_end, vrel_end, kind, status), _, log, n_imp, n_col = _run_kernel(
            CHAOTIC, phase, vrel, 200.0
        )
        assert status == OK
        if n_col:
            continue
        assert kind == IMPACT
        expected = 2 * n_imp * math.log(CHAOTIC.alpha) + math.log(vrel / vrel_end)
        assert log.sum() == pytest.approx(expected, rel=1e-9, abs=1e-8)
        assert log[0] > 0 > log[1]  # chaotic: one growing, one shrinking direction
        checked += 1
    assert checked >= 3


def _lifted_after(p, phase, vrel, n):
    out = (np.empty(n), np.empty(n), np.empty(n), np.empty(n, np.int64))
    _, n_done, status = flat_run(
        FlatState(0.0, phase, vrel, IMPACT), p.kernel(), n, FlatArrays(*out)
    )
    assert status == OK and n_done == n and np.all(out[3] == IMPACT)
    return np.array([out[0][-1] * TWO_PI + out[1][-1], out[2][-1]])


def _fd_product(p, phase, vrel, n):
    """Central differences of the lifted phase and vrel after ``n`` events (2, 2)."""
    steps = np.array([1e-7, 1e-7 * vrel])
    fd = np.empty((2, 2))
    for c in range(2):
        dz = np.zeros(2)
        dz[c] = steps[c]
        plus = _lifted_after(p, phase + dz[0], vrel + dz[1], n)
        minus = _lifted_after(p, phase - dz[0], vrel - dz[1], n)
        fd[:, c] = (plus - minus) / (2 * steps[c])
    return fd


@pytest.mark.parametrize("phase, vrel", [(1.0, 20.0), (4.0, 7.0), (5.5, 33.0)])
@pytest.mark.parametrize("periods", [1.0, 4.0])
def test_tangent_frame_agrees_with_finite_differences_of_whole_trajectories(phase, vrel, periods):
    p = CHAOTIC
    (_, _, _, kind, status), frame, log, n_imp, n_col = _run_kernel(p, phase, vrel, periods)
    assert status == OK and n_col == 0 and kind == IMPACT and n_imp >= 1
    fd = _fd_product(p, phase, vrel, n_imp)
    # QR of the product: |first column| = R00, first frame vector = its direction, det = R00 R11
    assert log[0] == pytest.approx(math.log(np.linalg.norm(fd[:, 0])), abs=1e-6)
    direction = fd[:, 0] / np.linalg.norm(fd[:, 0])
    assert frame[:2] == pytest.approx(direction, abs=1e-6)
    # det from nearly parallel columns: the differences' relative error (~ eps / step,
    # 1e-9) is multiplied by |c1| |c2| / |det|; a wrong Jacobian is off by O(1)
    cancel = np.prod(np.linalg.norm(fd, axis=0)) / abs(np.linalg.det(fd))
    assert log.sum() == pytest.approx(math.log(abs(np.linalg.det(fd))), abs=1e-9 * cancel + 1e-7)


def test_a_stick_forgets_the_state_and_collapses_the_frame():
    """Perturbed starts that stick are released at the same event: the tangent map is zero."""
    p = Params(f=58.0)  # Gamma = 1.35, alpha = 0.5: complete chattering
    n = 400
    finals = []
    for dphase in (0.0, 1e-6):
        out = (np.empty(n), np.empty(n), np.empty(n), np.empty(n, np.int64))
        flat_run(FlatState(0.0, 2.0 + dphase, 10.0, IMPACT), p.kernel(), n, FlatArrays(*out))
        first_release = int(np.argmax(out[3] == STICK)) + 1
        finals.append((out[0][first_release], out[1][first_release], out[2][first_release]))
    assert finals[0] == finals[1]
    _, _, _, _, n_col = _run_kernel(p, 2.0, 10.0, 20.0)
    assert n_col >= 1
    res = flat_lyapunov_from(p, [2.0], [10.0], t=1.0)
    assert np.all(res.exponents() == -math.inf)
    assert np.all(np.isfinite(res.conditional_exponents()))


def test_the_flight_from_a_release_does_not_depend_on_the_release_phase():
    """At the release phase the floor's acceleration is -g: a particle released later flies
    the same flight to first order, so the phase column of the release flight's Jacobian is
    zero (rounding aside), and finite differences of whole flights agree.  The tangent run
    therefore restarts its frame at the landing, not at the release (a carried identity
    would add the log of a rounding error per stick)."""
    from bbdyn.core.flat import flat_event
    from bbdyn.core.flat_jacobian import flat_map_jacobian_entries
    from bbdyn.core.plate import release_window
    from bbdyn.core.status import RELEASE

    for f in (58.0, 70.0, 85.2):
        kp = Params(f=f).kernel()
        theta_r = release_window(kp.gamma)[0]
        _, _, j00, j01, j10, j11, status = flat_map_jacobian_entries(theta_r, 0.0, kp)
        assert status == OK
        assert abs(j00) < 1e-12 and abs(j10) < 1e-12 * kp.A * kp.w**2
        assert abs(j01) > 1e-3 and abs(j11) > 1e-3  # the velocity column does not vanish
        # one-sided (no release before theta_r): the landing moves by O(dtheta^2)
        landing = [flat_event(0.0, theta_r + d, 0.0, RELEASE, kp) for d in (0.0, 1e-6, 1e-5)]
        assert all(e[4] == OK for e in landing)
        lifted = np.array([e[0] * TWO_PI + e[1] for e in landing])
        slopes = np.abs(lifted[1:] - lifted[0]) / np.array([1e-6, 1e-5])
        assert slopes[1] < 1e-3 and slopes[0] < 0.2 * slopes[1]  # O(dtheta), not O(1)


@pytest.mark.parametrize("transient", [0.0, 3.0])
def test_gamma_below_one_gives_no_positive_exponent(transient):
    """Stuck for good during the measurement or already during the transient."""
    p = params_at_gamma(0.8, alpha=ALPHA)
    res = flat_lyapunov(p, 6, t=2.0, transient=transient, seed=2)
    # measured from the first event (within a period of the start) to the end of the run
    d = res["duration"].sum(axis=1)
    assert np.all((d > 2.0 - 1.0 / p.f) & (d <= 2.0 + 1e-12))
    s = res.summary()
    assert s["stuck_fraction"] == 1.0
    if transient > 0:  # nothing measured between sticks
        assert np.all(np.isnan(res.conditional_exponents())) and math.isnan(s["cond_lam1_per_s"])
    assert set(res["status"]) == {STUCK_FOREVER}
    assert np.all(res.exponents() == -math.inf)
    # every particle ends stuck for good, having collapsed its frame
    assert np.all(res["collapses"].sum(axis=1) >= 1)


def test_windows_converge_and_summary_has_errors_over_particles():
    res = flat_lyapunov(CHAOTIC, 6, t=4.0, transient=0.5, windows=4, seed=5)
    lam_w = res.window_exponents()
    s = res.summary()
    assert np.all(lam_w > 0) and s["cond_lam1_per_s"] > 0 > s["cond_lam2_per_s"]
    # each window agrees with the pooled value within a few particle standard errors x sqrt(windows)
    assert np.all(np.abs(lam_w - s["cond_lam1_per_s"]) < 5 * s["cond_lam1_per_s_se"] * 2)
    # same seed, same numbers
    again = flat_lyapunov(CHAOTIC, 6, t=4.0, transient=0.5, windows=4, seed=5)
    assert np.array_equal(again["log_growth"], res["log_growth"])


def test_bad_input_is_refused_with_the_parameter_named():
    p = Params(f=58.0)
    with pytest.raises(ValueError, match="t must be"):
        flat_lyapunov(p, 2, t=0.0)
    with pytest.raises(ValueError, match="n must be"):
        flat_lyapunov(p, 0, t=1.0)
    with pytest.raises(ValueError, match="windows must be"):
        flat_lyapunov(p, 2, t=1.0, windows=0)
    with pytest.raises(ValueError, match="per must be"):
        flat_lyapunov(p, 1, t=0.1).exponents("year")
    with pytest.raises(ValueError, match="less than one driving period"):
        flat_lyapunov(p, 2, t=1e-300)


def test_window_agreement_is_a_chi2_test_of_the_window_means():
    """Synthetic exponents, 400 particles x 4 windows: with one mean in every window the
    chi^2 follows its distribution (mean = dof over 2000 sets, false alarms near WINDOW_P_MIN);
    a drift of a few standard errors per window is flagged."""
    from bbdyn.lyapunov import WINDOW_P_MIN, window_agreement

    rng = np.random.default_rng(4)
    n, w = 400, 4
    elapsed = rng.uniform(1.0, 2.0, (n, w))
    tests = [window_agreement(rng.normal(3.0, 0.5, (n, w)) * elapsed, elapsed)
             for _ in range(2000)]  # fmt: skip
    chi2 = np.array([t["window_chi2"] for t in tests])
    assert tests[0]["window_dof"] == w - 1
    # variances estimated from n particles widen chi^2(w - 1) by about (n - 1) / (n - 3)
    assert abs(chi2.mean() - (w - 1) * (1 + 2 / (n - 3))) < 4 * chi2.std() / math.sqrt(chi2.size)
    assert np.mean([not t["windows_agree"] for t in tests]) < 10 * WINDOW_P_MIN
    drift = rng.normal(3.0, 0.5, (n, w)) + np.arange(w) * 3 * 0.5 / math.sqrt(n)
    flagged = window_agreement(drift * elapsed, elapsed)
    assert not flagged["windows_agree"] and flagged["window_p"] < WINDOW_P_MIN
    one = window_agreement(np.ones((n, 1)), np.ones((n, 1)))  # nothing to compare
    assert one["windows_agree"] and math.isnan(one["window_p"])


def test_lyapunov_command_warns_when_the_windows_drift(capsys):
    """55 Hz: the particles creep onto their attractor during the run, the four windows'
    exponents fall from about -0.3 to -2.4 /s, many errors apart: a one-line warning and
    ``windows_agree: false`` in the JSON; at 85.2 Hz they agree, no warning."""
    import json

    from bbdyn.commands.cli import main

    for f, agree in (("55", False), ("85.2", True)):
        assert main(["lyapunov", "--f", f, "--json"]) == 0
        out, err = capsys.readouterr()
        s = json.loads(out)
        assert s["windows_agree"] is agree and (s["window_p"] < 1e-3) is not agree
        warned = [line for line in err.splitlines() if "warning" in line]
        assert len(warned) == (0 if agree else 1), err


def _tables_script():
    """``docs/data/lyapunov_tables.py``, which computes the tables of docs/lyapunov.md."""
    import importlib.util

    path = Path(__file__).resolve().parents[1] / "docs" / "data" / "lyapunov_tables.py"
    spec = importlib.util.spec_from_file_location("lyapunov_tables", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _committed_tables() -> dict:
    path = Path(__file__).resolve().parents[1] / "docs" / "data" / "lyapunov.json"
    return json.loads(path.read_text())


def _without_rounding(table: dict) -> list:
    """The rows of a spectrum table without the column of rounding-level differences."""
    assert table["columns"][-1] == "largest difference"
    return [row[:-1] for row in table["rows"]]


def test_the_docs_tables_are_what_the_code_computes():
    """docs/data/lyapunov.json (the tables of docs/lyapunov.md) is what the code computes
    now, and the page's sentence holds in it: between sticks neighbouring flat-ball states
    separate at 70 and 85.2 Hz and approach at 58 Hz."""
    script, committed = _tables_script(), _committed_tables()
    fresh = script.tables(long=False, cost=False)  # timings are not reproducible
    for key in ("flat", "flat_orbits", "billiard", "billiard_orbits", "billiard_spectrum_free",
                "billiard_orbit_spectrum"):  # fmt: skip
        assert json_close(fresh[key], committed[key]), f"{key}: run {script.COMMAND}"
    # the spectrum without its last column, the rounding-level difference of the QR sum and
    # the closed form (which depends on how the kernels were compiled)
    assert _without_rounding(fresh["billiard_spectrum"]) == _without_rounding(
        committed["billiard_spectrum"]
    ), f"billiard_spectrum: run {script.COMMAND}"
    cond = {float(r[0]): float(r[3].split("±")[0]) for r in committed["flat"]["rows"]}
    assert cond[70.0] > 0 and cond[85.2] > 0 and cond[58.0] < 0
    # the spectrum's sentences: every particle sticks at 70, 85.2 and 88.4 Hz (one finite
    # exponent), the 58 Hz locked attractor never does (four finite exponents), and the QR
    # sum is the closed form to the digits shown
    for row in committed["billiard_spectrum"]["rows"]:
        f, name, stuck, lam, qr, closed = row[0], row[1], row[3], row[5:9], row[9], row[10]
        assert qr == closed, row
        if f != "58":
            assert stuck == "1.00" and lam[1:] == ["-inf"] * 3, row
        elif "locked" in name:
            assert stuck == "0.00" and "-inf" not in lam, row
            # its horizontal pair adds up to about f log beta (up to the flux term), the vertical
            # pair to 2 f log alpha
            p, values = Params(f=58.0), [float(x.split("±")[0]) for x in lam]
            assert values[0] + values[1] == pytest.approx(p.f * math.log(p.beta), rel=0.1)
            assert values[2] + values[3] == pytest.approx(2 * p.f * math.log(p.alpha), rel=0.01)


@pytest.mark.slow
def test_longer_billiard_runs_in_the_docs_page_come_from_the_code():
    """The convergence tables of docs/lyapunov.md (n = 100, t = 50 s, transient 5 s; ~1 min)
    and their sentences: every exponent but the 58 Hz trapped cycle agrees with the short runs
    within two combined standard errors; that one does not."""
    script, committed = _tables_script(), _committed_tables()
    long = script.billiard_groups(100, 50.0, 5.0)
    assert script.billiard_table(long) == committed["billiard_long"]
    assert _without_rounding(script.spectrum_table(long)) == _without_rounding(
        committed["billiard_spectrum_long"]
    )
    assert script.free_spectrum_table(long) == committed["billiard_spectrum_free_long"]
    short_groups = script.billiard_groups()
    convergence = script.spectrum_convergence(short_groups, long)
    assert convergence == committed["spectrum_convergence"]
    # the spectrum's sentence: all but the trapped cycle agree within two combined errors
    for f, name, z1, z_free in convergence["rows"]:
        trapped = f == "58" and "trapped cycle" in name
        assert (max(float(z1), float(z_free)) > 2) == trapped, (f, name, z1, z_free)
    short = {(f, name): g for f, _, name, _, g in short_groups}
    for f, _, name, _, g in long:
        if name == "all" or (f, name) not in short:
            continue
        s = short[(f, name)]
        z = abs(g["lam1_per_s"] - s["lam1_per_s"]) / math.hypot(
            g["lam1_per_s_se"], s["lam1_per_s_se"]
        )
        assert (z > 2) == (f == 58.0 and "trapped cycle" in name), (f, name, z)
