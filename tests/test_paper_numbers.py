"""The data behind docs/paper.md (and the energy statements of docs/diffusion.md and
docs/results.md): ``docs/data/paper.json`` is what ``docs/data/paper_numbers.py`` makes from
the committed results, its numbers agree with independent computations (closed forms, the
exact map, the scan's arrays recomputed here), and every verdict of the page rests on them.
"""

from __future__ import annotations

import importlib.util
import json
import math
from pathlib import Path

import numpy as np
import pytest
from json_trees import json_close

from bbdyn import Params
from bbdyn.flat.tongues import (
    frequency_at_gamma,
    gamma_hi_numeric,
    gamma_lo_numeric,
    tongue_gamma_hi,
    tongue_gamma_lo,
)

DOCS = Path(__file__).resolve().parents[1] / "docs"
PAPER = json.loads((DOCS / "data" / "paper.json").read_text())
D_TABLE = json.loads((DOCS / "data" / "classification_d_table.json").read_text())
#: The paper's numbers the page quotes (Matyas and Klages 2004, sections 3.2, 5).
PAPER_TONGUES = [(50.98, 61.56), (72.10, 76.71), (88.30, 90.95)]
PAPER_F0, PAPER_S_MAX, PAPER_F_77 = 49.77, 2.0004, 77.23


def figure(name: str) -> dict:
    npz = np.load(DOCS / "figures" / f"{name}.npz")
    return {k: npz[k] for k in npz.files}


def script():
    spec = importlib.util.spec_from_file_location(
        "paper_numbers", DOCS / "data" / "paper_numbers.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_script_reproduces_paper_json():
    """Running docs/data/paper_numbers.py on the committed inputs gives the committed JSON,
    so no number of the pages is stale with respect to its data."""
    built = json.loads(json.dumps(script().build()))
    assert json_close(built, PAPER)


def test_energy_ratio_recomputed_from_the_full_scan():
    """E / (A^2 w^2/2) above 62 Hz: range, median and share below 3, from the scan's arrays;
    "3-4 times" does not describe it (fewer than half of the points lie in [3, 4])."""
    s3 = figure("S3_full")
    p = Params(f=62.0)
    w = 2 * np.pi * s3["f"]
    reference = p.A**2 * w**2 / 2
    assert np.allclose(s3["E_reference"], reference, rtol=1e-12)
    m = s3["f"] >= 62.0
    ratio = (s3["E"] / reference)[m]
    stated = PAPER["energy"]["ratio_above_62"]
    assert math.isclose(np.median(ratio), stated["median"], rel_tol=1e-12)
    assert (ratio.min(), ratio.max()) == pytest.approx((stated["min"], stated["max"]), rel=1e-12)
    assert 100 * np.mean(ratio < 3) == pytest.approx(stated["percent_below_3"])
    assert stated["percent_3_to_4"] < 50 and stated["min"] < 1 < 3 < stated["median"] + 1


def test_energies_add_up_and_flights_have_twice_the_kinetic_height():
    """E = E_x + E_y + E_pot at every frequency, and where particles fly E_pot / E_y lies
    near 2 (free parabolas: <g y> = 2 <vy^2/2>), as docs/diffusion.md says."""
    s3 = figure("S3_full")
    assert np.allclose(s3["E"], s3["E_x"] + s3["E_y"] + s3["E_pot"], rtol=1e-9)
    stated = PAPER["energy"]["E_pot_over_E_y_moving"]
    assert 1.5 < stated["min"] < stated["median"] < stated["max"] < 3
    assert abs(stated["median"] - 2) < 0.1


def test_basin_fractions_sum_to_one():
    """Every frequency of the regime map: attractor fractions + unsettled = 1."""
    b1 = figure("B1_full")
    total = b1["fractions"].sum(axis=1) + b1["unsettled_fraction"]
    assert np.allclose(total, 1.0, atol=1e-12)
    assert PAPER["regimes"]["fractions_sum_max_dev"] < 1e-12
    for f in (58.0, 62.0):
        rows = [r for r in D_TABLE["rows"] if r["f"] == f and r["n"] == 1000]
        assert 0.95 <= sum(r["fraction"] for r in rows) <= 1.0


def test_77_hz_from_the_energy_argument():
    """A^2 w^2 / 2 = g (A + h): 77.19 Hz with g = 9.8 m/s^2, the paper's 77.23 Hz with
    9.81 m/s^2; the scan's peak on [76, 78] Hz lies within one grid step of it and stands
    above both neighbours by more than three combined standard errors."""
    p = Params(f=77.0)

    def f_of(g):
        return math.sqrt(2 * g * (p.A + 0.02)) / p.A / (2 * math.pi)

    stated = PAPER["peak_77"]
    assert round(f_of(9800.0), 2) == 77.19 and round(f_of(9810.0), 2) == PAPER_F_77
    assert stated["f_paper_g"] == pytest.approx(f_of(9800.0), rel=1e-14)
    assert stated["f_g_9810"] == pytest.approx(f_of(9810.0), rel=1e-14)
    assert abs(stated["f_peak"] - f_of(9800.0)) < stated["grid_step"]
    peak = stated["D_peak"]
    for n in stated["neighbours"]:
        assert peak["value"] - n["D"]["value"] > 3 * math.hypot(peak["se"], n["D"]["se"])
    assert stated["D_peak"] == PAPER["D_70_80"]["max"]["D"]  # the largest D on [70, 80] Hz


@pytest.mark.parametrize("k", [1, 2, 3])
def test_tongue_edges_closed_form_against_the_exact_map_and_the_paper(k):
    """The k/1 edges of the page are the closed form, which the exact map's multipliers
    reproduce; the paper's edges are the same cut to two decimals."""
    alpha = Params(f=60.0).alpha
    lo, hi = PAPER["setup"]["tongues"][k - 1]
    assert lo == pytest.approx(frequency_at_gamma(tongue_gamma_lo(k, alpha)), rel=1e-14)
    assert hi == pytest.approx(frequency_at_gamma(tongue_gamma_hi(k, alpha)), rel=1e-14)
    assert lo == pytest.approx(frequency_at_gamma(gamma_lo_numeric(k, alpha)), rel=1e-9)
    assert hi == pytest.approx(frequency_at_gamma(gamma_hi_numeric(k, alpha)), rel=1e-9)
    for ours, theirs in zip((lo, hi), PAPER_TONGUES[k - 1], strict=True):
        assert theirs <= ours < theirs + 0.01


def test_the_paper_slips():
    """Gamma = 1 is not at 49.77 Hz; the arc length is not 2.0004 mm; Gamma = 2 at 70.46 Hz."""
    setup = PAPER["setup"]
    assert Params(f=setup["f_gamma_1"]).gamma == pytest.approx(1.0, rel=1e-14)
    assert Params(f=PAPER_F0).gamma < 0.999 and setup["f_gamma_1"] - PAPER_F0 > 0.05
    p = Params(f=60.0)
    assert setup["s_max"] == pytest.approx(2 * p.R * math.asin(p.d / (2 * p.R)), rel=1e-15)
    assert setup["s_max"] - PAPER_S_MAX > 1e-4
    assert Params(f=setup["f_gamma_2"]).gamma == pytest.approx(2.0, rel=1e-14)
    h = p.R - math.sqrt(p.R**2 - p.d**2 / 4)
    assert setup["h"] == pytest.approx(h, rel=1e-12)


def test_the_wedge_cycle_is_periodic_and_trapped():
    """At 58 and 62 Hz the largest attractor is a cycle: a whole number of collisions per
    period, no jump, D zero; the other is the 1/1 locked orbit, which jumps."""
    for f in ("58", "62"):
        cycle, locked = PAPER["attractors_58_62"][f]
        n = cycle["collisions_per_period"]
        assert n > 2 and abs(n - round(n)) < 1e-9
        assert cycle["jumps_per_period"] == 0
        assert abs(cycle["D"]["value"]) <= 2 * cycle["D"]["se"] + 1e-12
        assert locked["character"] == "locked (k = 1)" and locked["jumps_per_period"] > 0
        assert locked["collisions_per_period"] == pytest.approx(1.0)
        assert cycle["fraction"] > locked["fraction"] > 0


def test_classification_table_d_is_the_einstein_d_of_its_particles():
    for row in D_TABLE["rows"]:
        D, own = row["D"], row["D_own"]
        assert abs(D["value"] - own["value"]) <= 1e-9 * (1 + abs(D["value"])), row
        if row["D_simulate"] is not None and row["fraction"] == 1.0:
            assert row["D_simulate"]["value"] == pytest.approx(D["value"], rel=1e-9)


def test_the_verdicts_rest_on_the_data():
    """Each verdict of docs/paper.md, as a condition on the numbers it quotes."""
    P = PAPER
    # P6: more energy flags than chance, most of them below 58 Hz
    flags = P["onset"]["energy_not_stationary"]
    assert (
        flags["count"] > 3 * flags["expected_by_chance"] and flags["below_58"] > flags["count"] / 2
    )
    # P7: about two decades to the 3/1 peak, less to the 1/1 peak; D zero at points of [70, 80]
    d = P["D_70_80"]
    assert d["peaks"]["k3"]["decades"] >= 2 > d["peaks"]["k1"]["decades"] >= 1.5
    assert d["zero"] > 0 and d["zero_regimes"] == ["a"] and d["median"] < 1
    # P8: the 2/1 locked orbit from the high box only
    assert P["resonance_74"]["reference_box_in_tongue"]["locked_points"] == 0
    for f in ("74", "74.5"):
        locked = [a for a in P["resonance_74"][f]["attractors"] if a["locking_k"] == 2]
        assert len(locked) == 1 and locked[0]["fraction"] > 0
    # P9: E_x follows D more closely than E; no equipartition; E below the line somewhere
    e = P["energy"]
    assert e["spearman_E_x_D"] > e["spearman_E_D"] and e["min_E_y_over_E_x"] > 1
    assert e["below_reference"]["points"] > 0 and e["min_ratio"] < 1
    # P10: D and E_x larger above 80 Hz; P11: E rises across [58, 62] Hz
    assert d["median_80_95"] > 10 * d["median"] and d["median_E_x_80_95"] > d["median_E_x_70_80"]
    assert e["slope_E_58_62"] > 0 and e["E_62"]["value"] > e["E_58"]["value"]
    # P12: onset between 57 and 58 Hz, D above 3 errors by 58.6 Hz
    o = P["onset"]
    assert 57.0 < o["first_non_a"] < 57.8 and o["first_D_3se"] <= 58.6
    # P13: no (b)(ii) anywhere; the paper's (b)(ii) intervals are (b)(i) with two attractors
    r = P["regimes"]
    assert r["b_ii_anywhere"] == 0 and r["b_ii_fractions"]["max_n_attractors"] == 2
    assert all(iv["b(i)"] == iv["points"] for iv in r["b_ii"])
    assert r["b_ii_fractions"]["second"][0] > 0
    # P15, P17: one attractor per frequency; the "other" points of (d) in the 3/1 tongue
    lo3, hi3 = P["setup"]["tongues"][2]
    assert r["c"]["max_attractors"] == 1 and r["d"]["max_attractors"] == 1
    assert all(lo3 <= f <= hi3 for f in r["d"]["other_at"])
    # P18: six regions, region 5 skipped, but not every second round
    o88 = P["orbit_88"]
    assert o88["major_regions"] == 6 and o88["full"] > 0 and o88["skip5"] > 0
    assert o88["alternating_pairs"] < 0.75 * o88["pairs"] and o88["regime"] != "b(ii)"
    # docs/classification.md: 85.2 Hz intermittent (d), 88.4 Hz not locked ("other")
    c85, c88 = P["classified_85_88"]["85.2"], P["classified_85_88"]["88.4"]
    assert c85["regime"] == "d" and 0.05 <= c85["locked_fraction"] < 0.9
    assert c88["regime"] == "other" and c88["locked_fraction"] < 0.9 and c88["dominant_k"] == 2
    # P19: the largest D in the 3/1 tongue; sticky where D is near zero
    assert lo3 <= P["D_max"]["f"] <= hi3
    assert r["stuck_still"] > 5 * r["stuck_moving"]
    # P20: D_rw shaped like D but below it; tau several times d / sqrt(2 E_x)
    rw = P["random_walk"]
    assert rw["spearman_D_rw_D"] > 0.9 and rw["D_rw_over_D_median"] < 0.5
    assert rw["tau_sqrt2Ex_over_d"]["median"] > 2
    # P21: r near 19 at few frequencies; D_a (r = 19) grows much slower than D_rw on [80, 90]
    assert rw["r_within_10pc_of_19"]["points"] < rw["points"] / 4
    assert rw["slope_80_90"]["D_a_paper"] < 0.5 * rw["slope_80_90"]["D_rw"]
    assert rw["D_a_defined_from"] > P["setup"]["f_gamma_2"]
    # P22: forward jumps dominate; P23: D_n approaches D with n, D_0/D scatters beyond noise
    gk = P["green_kubo"]
    assert gk["p_f"][0] > 2 * gk["p_b"][1]
    within = [gk["orders"][n]["within_2se"] for n in ("0", "2", "4", "7", "10")]
    assert within == sorted(within) and within[0] == 0 and within[-1] > 0.8 * gk["points"]
    assert gk["orders"]["0"]["ratio_chi2_dof"] > 1.4
    assert all(gk["orders"][n]["ratio_chi2_dof"] < 1.25 for n in ("2", "4", "7", "10"))
    # docs/results.md: 70.0 Hz moving, 70.2 Hz trapped with E below the line
    moving, trapped = P["results_70"]["70"], P["results_70"]["70.2"]
    assert moving["z"] > 3 and moving["regime"] == "d" and moving["E_over_reference"] > 2
    assert abs(trapped["z"]) < 2 and trapped["regime"] == "a" and trapped["E_over_reference"] < 1


def test_green_kubo_zeroth_order_is_the_random_walk():
    """D_0 = d^2 / (2 tau) at every frequency of S10 (the series' first term, P22)."""
    s10 = figure("S10_full")
    d = Params(f=85.0).d
    assert np.allclose(s10["D_n"][:, 0], d**2 / (2 * s10["tau"]), rtol=1e-3)
    assert np.all(s10["p_f"] + s10["p_b"] == pytest.approx(1.0))


CREEP = json.loads((DOCS / "data" / "creep.json").read_text())


def test_creep_to_the_wedges_data():
    """docs/diffusion.md: just above Gamma = 1 no particle jumps, yet particles move, most of
    them towards a wedge, and more sit on a wedge at the end; the windowed D grows at 51 Hz;
    at 53 Hz every particle has arrived by 100 s and hardly anything moves at the end."""
    for f in ("51", "53"):
        c = CREEP[f]
        assert c["jumps_per_particle_per_s"] == 0
        assert c["closer_20_100"] <= c["moved_20_100"] <= c["n"]
        assert c["closer_20_100"] > c["moved_20_100"] / 2
        assert c["on_wedge_100"] > c["on_wedge_20"]
    windows = [w["value"] for w in CREEP["51"]["D_windows"]]
    assert windows == sorted(windows) and windows[-1] > 1.2 * windows[0]
    c53 = CREEP["53"]
    assert c53["on_wedge_100"] == c53["n"] and c53["moved_80_100_max"] < CREEP["on_wedge_mm"]
    assert c53["moved_80_100"] < CREEP["51"]["moved_80_100"]


@pytest.mark.slow
def test_creep_numbers_reproduce():
    """docs/data/creep_numbers.py (two small ensembles) gives the committed creep.json."""
    spec = importlib.util.spec_from_file_location("creep", DOCS / "data" / "creep_numbers.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    for f in module.FREQUENCIES:
        assert json_close(json.loads(json.dumps(module.creep(f))), CREEP[f"{f:g}"])
