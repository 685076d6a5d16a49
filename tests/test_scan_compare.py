"""benchmarks/scan_compare.py: z scores of two scans, on synthetic scans with known truth."""

import json
import math

import numpy as np
from derivation_loader import ROOT, load_benchmark


def _module():
    return load_benchmark("scan_compare")


def _scan(f, truth, err, rng, shift=0.0, rounding=0.0):
    """A synthetic scan: every quantity is ``truth + shift err`` plus N(0, err) noise, with
    rounding bounds ``rounding``."""
    out = {"f": f}
    for name in ("D", "E", "E_x"):
        out[name] = truth + shift * err + rng.normal(0.0, err)
        out[name + "_err"] = err
        out[name + "_round"] = np.full(f.size, rounding)
    return out


def test_two_samples_of_the_same_truth_look_like_noise_and_a_shift_does_not():
    m = _module()
    rng = np.random.default_rng(3)
    f = np.round(np.arange(49.8, 95.0001, 0.2), 9)
    truth, err = np.sin(f), np.full(f.size, 0.1)
    same = m.z_scores(_scan(f, truth, err, rng), _scan(f[::-1], truth[::-1], err, rng))
    assert same["n_points"] == f.size
    for name in ("D", "E", "E_x"):
        # z = N(0, 2 err^2) / (sqrt(2) err): standard normal; 227 points
        assert abs(same[name]["std_z"] - 1.0) < 0.15
        assert same[name]["n_beyond_3"] <= 3
    shifted = m.z_scores(_scan(f, truth, err, rng), _scan(f, truth, err, rng, shift=8.0))
    assert shifted["D"]["beyond_3"] > 0.9  # mean z = 8 / sqrt(2)


def test_exact_zeros_count_as_agreement_and_are_reported_when_they_differ():
    m = _module()
    f = np.array([49.8, 50.0])
    zeros = np.zeros(2)
    names = ("D", "D_err", "D_round", "E", "E_err", "E_round", "E_x", "E_x_err", "E_x_round")
    old = {"f": f, **{k: zeros for k in names}}
    new = dict(old, D=np.array([0.0, 1e-3]))
    out = m.z_scores(old, new)
    assert out["D"]["n_exact"] == 2 and out["D"]["exact_disagree_f"] == [50.0]
    assert out["E"]["exact_disagree_f"] == []


def test_differences_within_the_rounding_bound_are_agreement_and_beyond_it_are_not():
    """Deterministic points (errors at rounding level): a difference within twice the rounding
    bound gives z = 0; one beyond it keeps its (huge) z."""
    m = _module()
    f, tiny = np.array([56.6, 56.8]), np.full(2, 1e-14)
    old = {"f": f}
    for name in ("D", "E", "E_x"):
        old.update({name: np.full(2, 400.0), name + "_err": tiny})
        old[name + "_round"] = np.full(2, 1e-9)
    new = dict(old, E=np.array([400.0 + 1.5e-9, 400.0 + 3e-9]))
    out = m.z_scores(old, new)
    assert out["E"]["within_rounding_f"] == [56.6]
    assert out["E"]["z"][0] == 0.0 and out["E"]["z"][1] > 1e4


def test_the_current_full_scan_agrees_with_s3_full():
    """docs/scan_compare/full_scan.json against docs/figures/S3_full, recomputed: the saved
    comparison is this one; as two samples of the same physics, no D beyond 3 combined errors,
    few values of all three beyond 3 (0.27 % of 681 expected), chi^2/dof near 1; below 57 Hz
    (particles locked to a cycle) the energies agree to rounding; above 65 Hz z spreads like a
    standard normal variable."""
    m = _module()
    folder = ROOT / "docs" / "scan_compare"
    saved = json.loads((folder / "full_scan_compare.json").read_text())
    assert saved["provenance"]["new"]["file"] == "docs/scan_compare/full_scan.json"
    assert saved["provenance"]["old"]["file"] == "docs/figures/S3_full.npz"
    again = m.z_scores(m.load_old(ROOT / "docs" / "figures" / "S3_full.npz"),
                       m.load_new(folder / "full_scan.json"))  # fmt: skip
    f = again["f"]
    assert again["n_points"] == saved["n_points"] == f.size
    beyond = 0
    for name in ("D", "E", "E_x"):
        assert {k: v for k, v in again[name].items() if k != "z"} == saved[name]
        z = again[name]["z"]
        beyond += int((np.abs(z) > 3.0).sum())
        assert 0.5 < again[name]["chi2_per_dof"] < 1.5
        assert 0.8 < z[f > 65.0].std(ddof=1) < 1.2
        if name != "D":
            assert np.abs(z[f < 57.0]).max() < 1e-4
    assert np.abs(again["D"]["z"]).max() < 3.0
    assert beyond <= 5  # Poisson mean 1.8: 5 or more has probability 3 %


def test_the_scan_wall_time_belongs_to_the_scan():
    """The wall time of the committed full scan names that scan, and its CPU time is the sum
    of its points' (two workers on two cores: wall at least half the CPU time)."""
    folder = ROOT / "docs" / "scan_compare"
    scan = json.loads((folder / "full_scan.json").read_text())
    wall = json.loads((folder / "full_scan_wall.json").read_text())
    assert wall["scan"] == "docs/scan_compare/full_scan.json"
    assert math.isclose(scan["cpu_s"], sum(p["cpu_s"] for p in scan["points"]), rel_tol=1e-9)
    assert scan["cpu_s"] / 2 <= wall["wall_s"] <= scan["cpu_s"]
