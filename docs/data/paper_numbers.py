"""Every number that docs/paper.md, docs/results.md and docs/diffusion.md state about bbdyn
beside the reference paper (Matyas and Klages, Physica D 187 (2004) 165), derived from
committed results into ``docs/data/paper.json``.

Run from the repository root:

    python docs/data/paper_numbers.py            # read the committed files, write paper.json
    python docs/data/paper_numbers.py --fresh    # first rerun the small runs of FRESH

Inputs (all committed): the full frequency scan ``docs/figures/S3_full`` (D, E, E_x, E_y,
E_pot at 227 frequencies, 49.8-95 Hz, n = 1000, t = 200 s), the regime map ``B1_full``
(classification at the same frequencies, basin fractions), the random walk ``S9_full``
(D_rw, D_a, r, tau), Green-Kubo ``S10_full`` (D_n on 84.6-86.4 Hz), the tongue figure
``S1``, the geometry ``S2``, the 88.4 Hz orbit ``S8``, the per-attractor D table
``docs/data/classification_d_table.json`` (``docs/classification_d_table.py``) and the
runs of ``FRESH`` (each file holds its exact command). Closed forms (tongue edges,
Gamma = 1 and 2, the 77 Hz argument) are evaluated here. The JSON records the inputs'
SHA-256, the commit that made each figure and the bbdyn version.

``PAPER`` holds the paper's own numbers (with their sections), only to compute differences;
the pages quote them in words. Every other number comes from the inputs. Keys are grouped
by the paper's statements P1-P25 (``P7``, ``P16``, ...) and by page (``energy``,
``results_70``); a ``{"value": v, "se": s}`` pair is a number with its standard error.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np

DOCS = Path(__file__).resolve().parents[1]
ROOT = DOCS.parent
OUT = DOCS / "data" / "paper.json"
FIGURES = ("S1", "S2", "S3_full", "S8", "S9_full", "S10_full", "B1_full")
D_TABLE = DOCS / "data" / "classification_d_table.json"
#: Small fresh runs: {file under docs/data: [bbdyn command lines]}. The 2/1 resonance from
#: initial conditions above the reference box (vy+ in (40, 400] mm/s), and 85.2 and 88.4 Hz
#: from the reference box (docs/classification.md, "Uncertain cases").
FRESH = {
    "classify_74_high.json": [
        f"classify --f {f} --box high --n 200 --t 50 --seed 0 --threads 1 --json".split()
        for f in ("74.0", "74.5")
    ],
    "classify_85_88.json": [
        f"classify --f {f} --n 1000 --t 50 --seed 0 --threads 1 --json".split()
        for f in ("85.2", "88.4")
    ],
}
#: The paper's numbers (section in the comment), to compute differences only.
PAPER = {
    "f0": 49.77,  # sec. 5 (a): Gamma = 1
    "s_max": 2.0004,  # sec. 3.2
    "tongues": [[50.98, 61.56], [72.10, 76.71], [88.30, 90.95]],  # sec. 3.2
    "h": 0.02,  # sec. 5 (c), floor bump height in mm
    "f_77": 77.23,  # sec. 5 (c)
    "g_77": 9810.0,  # mm/s^2: the g that gives 77.23 Hz
    "r": 19.0,  # sec. 6, E_y / E_x
    "D_70_80": (1.0, 2.0),  # sec. 4, "around one or two" mm^2/s on [70, 80] Hz
    "b_i": [[57.0, 57.8], [60.4, 61.8], [63.4, 65.6]],  # sec. 5 (b)(i)
    "b_ii": [[58.0, 60.2], [62.0, 63.2]],  # sec. 5 (b)(ii)
    "c": [65.8, 81.0],  # sec. 5 (c)
    "d": [81.1, 95.0],  # sec. 5 (d)
    "gk": [84.6, 86.4],  # sec. 6
}
#: Regime labels of the B1 codes (bbdyn.scenes.b1_regime_map.LABELS).
LABELS = ("a", "b(i)", "b(ii)", "c", "d", "other")
#: D is "zero" where it lies within this many standard errors of 0.
Z_ZERO = 2.0


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def load(name: str) -> tuple[dict, dict]:
    """Arrays and metadata of the committed figure ``name``."""
    npz = np.load(DOCS / "figures" / f"{name}.npz")
    meta = json.loads((DOCS / "figures" / f"{name}.json").read_text())["meta"]
    return {k: npz[k] for k in npz.files}, meta


def pair(value, se) -> dict:
    return {"value": float(value), "se": float(se)}


def at(arrays: dict, f: float) -> int:
    """Index of frequency ``f`` (Hz) on the grid of ``arrays``."""
    i = int(np.argmin(np.abs(arrays["f"] - f)))
    assert abs(arrays["f"][i] - f) < 1e-6, f"{f} Hz is not on the grid"
    return i


def within(arrays: dict, lo: float, hi: float) -> np.ndarray:
    return (arrays["f"] >= lo - 1e-9) & (arrays["f"] <= hi + 1e-9)


def runs(f: np.ndarray, mask: np.ndarray) -> list[str]:
    """Maximal runs of consecutive grid points where ``mask`` holds, as text (Hz):
    ``"49.8-58"`` for a run, ``"70.2"`` for a single point."""
    out, start = [], None
    for i, m in enumerate(mask):
        if m and start is None:
            start = i
        if start is not None and (not m or i == len(mask) - 1):
            lo, hi = f[start], f[i if m else i - 1]
            out.append(f"{lo:g}" if lo == hi else f"{lo:g}-{hi:g}")
            start = None
    return out


def spearman(a, b) -> float:
    from scipy.stats import spearmanr

    return float(spearmanr(a, b).statistic)


def slope(x, y) -> float:
    return float(np.polyfit(x, y, 1)[0])


def regime_counts(b1: dict, lo: float, hi: float) -> dict:
    m = within(b1, lo, hi)
    codes = b1["regime"][m].astype(int)
    counts = {lab: int(np.sum(codes == i)) for i, lab in enumerate(LABELS)}
    return {"points": int(codes.size), "max_attractors": int(b1["n_attractors"][m].max())} | {
        k: v for k, v in counts.items() if v
    }


def setup(s2_meta: dict, s1_meta: dict) -> dict:
    """P1, P5 and the slips: closed forms against the paper's numbers."""
    from bbdyn import Params
    from bbdyn.flat.tongues import frequency_at_gamma, tongue_gamma_hi, tongue_gamma_lo

    p = Params(f=PAPER["f0"])  # A, g, alpha, R, d: the defaults (f does not enter)
    tongues = [
        [
            float(frequency_at_gamma(tongue_gamma_lo(k, p.alpha))),
            float(frequency_at_gamma(tongue_gamma_hi(k, p.alpha))),
        ]
        for k in (1, 2, 3)
    ]
    diff = np.abs(np.array(tongues) - np.array(PAPER["tongues"]))
    return {
        "f_gamma_1": float(frequency_at_gamma(1.0)),
        "gamma_at_paper_f0": Params(f=PAPER["f0"]).gamma,
        "f_gamma_2": float(frequency_at_gamma(2.0)),
        "s_max": p.s_max,
        "s_max_minus_paper": p.s_max - PAPER["s_max"],
        "h": s2_meta["key_numbers"]["h_mm"],
        "tongues": tongues,
        "tongues_max_diff_to_paper": float(diff.max()),
        "tongues_numeric_max_rel_dev": max(s1_meta["max_rel_dev_lo"], s1_meta["max_rel_dev_hi"]),
    }


def peak_77(s3: dict, h: float) -> dict:
    """P16: f where A^2 w^2 / 2 = g (A + h), with the paper's g and h, and the bump's h."""
    from bbdyn import Params

    p = Params(f=PAPER["f0"])  # A, g, alpha, R, d: the defaults (f does not enter)

    def f_of(g, hh):
        return math.sqrt(2.0 * g * (p.A + hh)) / p.A / (2.0 * math.pi)

    i = at(s3, 77.2)
    near = within(s3, 76.0, 78.0)
    k = int(np.flatnonzero(near)[np.argmax(s3["D"][near])])
    f_model = f_of(p.g, PAPER["h"])
    return {
        "f_paper_g": f_model,
        "f_g_9810": f_of(PAPER["g_77"], PAPER["h"]),
        "f_bump_h": f_of(p.g, h),
        "f_peak": float(s3["f"][k]),
        "D_peak": pair(s3["D"][k], s3["D_err"][k]),
        "peak_minus_formula": float(s3["f"][k]) - f_model,
        "grid_step": float(s3["f"][1] - s3["f"][0]),
        "neighbours": [
            {"f": float(s3["f"][j]), "D": pair(s3["D"][j], s3["D_err"][j])} for j in (i - 1, i + 1)
        ],
    }


def onset(s3: dict, b1: dict) -> dict:
    """P6, P12: trapped points, the first frequency with a diffusive attractor, D's rise."""
    from bbdyn.scans.frequency import P_FLAG

    above = s3["f"] > 54.0  # past the slow creep to the wedges (docs/diffusion.md)
    first_b1 = float(b1["f"][above & (b1["regime"] != 0)][0])
    i = at(b1, first_b1)
    sig = above & (s3["D"] > 3 * s3["D_err"])
    series = [56.8, 57.0, 57.2, 57.4, 57.6, 57.8, 58.0, 58.2, 58.4, 59.0, 60.0]
    not_stationary = s3["f"][s3["energy_stationary"] == 0]
    a_low = (b1["regime"] == 0) & (b1["f"] < 65.0)
    return {
        "trapped_exactly": [float(f) for f in s3["f"][s3["trapped"] == 1]],
        "regime_a_low": [float(b1["f"][a_low][0]), float(b1["f"][a_low][-1])],
        "first_non_a": first_b1,
        "first_non_a_second_fraction": float(b1["fractions"][i, 1]),
        "first_D_3se": float(s3["f"][sig][0]),
        "D_series": [
            {"f": f, "D": pair(s3["D"][at(s3, f)], s3["D_err"][at(s3, f)])} for f in series
        ],
        "energy_not_stationary": {
            "count": int(not_stationary.size),
            "expected_by_chance": s3["f"].size * P_FLAG,
            "below_58": int(np.sum(not_stationary < 58.0)),
            "first": float(not_stationary[0]),
            "last_below_58": float(not_stationary[not_stationary < 58.0][-1]),
            "above_58": [float(f) for f in not_stationary[not_stationary >= 58.0]],
        },
    }


def d_70_80(s3: dict, b1: dict, setup_: dict) -> dict:
    """P7, P10: D on [70, 80] Hz, the resonance peaks and their ratio in decades."""
    m = within(s3, 70.0, 80.0)
    D, se = s3["D"][m], s3["D_err"][m]
    k = int(np.argmax(D))
    zero = np.abs(D) <= Z_ZERO * se
    med = float(np.median(D))
    peaks = {}
    for name, (lo, hi) in (("k1", setup_["tongues"][0]), ("k3", setup_["tongues"][2])):
        t = within(s3, lo, hi)
        j = int(np.flatnonzero(t)[np.argmax(s3["D"][t])])
        peaks[name] = {
            "f": float(s3["f"][j]),
            "D": pair(s3["D"][j], s3["D_err"][j]),
            "decades": math.log10(s3["D"][j] / med),
        }
    j_above = int(np.argmax(np.where(within(s3, 61.6, 70.0), s3["D"], -np.inf)))
    hi = within(s3, 80.2, 95.0)
    return {
        "points": int(m.sum()),
        "median": med,
        "quartiles": [float(np.quantile(D, 0.25)), float(np.quantile(D, 0.75))],
        "in_paper_range": int(np.sum((D >= PAPER["D_70_80"][0]) & (D <= PAPER["D_70_80"][1]))),
        "zero": int(zero.sum()),
        "zero_regimes": sorted({LABELS[int(c)] for c in b1["regime"][m][zero]}),
        "max": {"f": float(s3["f"][m][k]), "D": pair(D[k], se[k])},
        "peaks": peaks,
        "max_above_k1": {
            "f": float(s3["f"][j_above]),
            "D": pair(s3["D"][j_above], s3["D_err"][j_above]),
        },
        "median_80_95": float(np.median(s3["D"][hi])),
        "median_E_x_70_80": float(np.median(s3["E_x"][m])),
        "median_E_x_80_95": float(np.median(s3["E_x"][hi])),
    }


def energies(s3: dict) -> dict:
    """P9, P11 and the energy statements of docs/diffusion.md and docs/results.md."""
    ratio = s3["E"] / s3["E_reference"]
    m = s3["f"] >= 62.0
    moving = m & (s3["D"] > 3 * s3["D_err"])
    below = ratio < 1.0
    i85 = at(s3, 85.2)
    jump = s3["f"] >= 57.4
    w = within(s3, 58.0, 62.0)
    return {
        "ratio_above_62": {
            "points": int(m.sum()),
            "min": float(ratio[m].min()),
            "f_min": float(s3["f"][m][np.argmin(ratio[m])]),
            "max": float(ratio[m].max()),
            "f_max": float(s3["f"][m][np.argmax(ratio[m])]),
            "median": float(np.median(ratio[m])),
            "percent_below_3": float(100 * np.mean(ratio[m] < 3.0)),
            "percent_3_to_4": float(100 * np.mean((ratio[m] >= 3.0) & (ratio[m] <= 4.0))),
        },
        "E_pot_over_E_y_moving": {
            "median": float(np.median((s3["E_pot"] / s3["E_y"])[moving])),
            "min": float(np.min((s3["E_pot"] / s3["E_y"])[moving])),
            "max": float(np.max((s3["E_pot"] / s3["E_y"])[moving])),
            "at_85_2": float(s3["E_pot"][i85] / s3["E_y"][i85]),
            "points": int(moving.sum()),
        },
        "below_reference": {"points": int(below.sum()), "runs": runs(s3["f"], below)},
        "min_ratio": float(ratio.min()),
        "spearman_E_D": spearman(s3["E"][jump], s3["D"][jump]),
        "spearman_E_x_D": spearman(s3["E_x"][jump], s3["D"][jump]),
        "min_E_y_over_E_x": float(np.min(s3["E_y"][jump] / s3["E_x"][jump])),
        "from_f": 57.4,
        "slope_E_58_62": slope(s3["f"][w], s3["E"][w]),
        "E_58": pair(s3["E"][at(s3, 58.0)], s3["E_err"][at(s3, 58.0)]),
        "E_62": pair(s3["E"][at(s3, 62.0)], s3["E_err"][at(s3, 62.0)]),
    }


def point(s3: dict, b1: dict, f: float) -> dict:
    """One frequency of the full scan and of the regime map."""
    i, j = at(s3, f), at(b1, f)
    D, se = float(s3["D"][i]), float(s3["D_err"][i])
    return {
        "f": f,
        "D": pair(D, se),
        "z": D / se if se > 0 else 0.0,
        "E_over_reference": float(s3["E"][i] / s3["E_reference"][i]),
        "stuck_fraction": float(s3["stuck_fraction"][i]),
        "regime": LABELS[int(b1["regime"][j])],
        "fractions": [float(x) for x in b1["fractions"][j] if x > 0],
        "unsettled": float(b1["unsettled_fraction"][j]),
        "ergodic": bool(b1["ergodic"][j]),
    }


def regimes(s3: dict, b1: dict) -> dict:
    """P13-P15, P17, P19: the paper's regime intervals against bbdyn's classification."""
    out = {}
    for key in ("b_i", "b_ii"):
        out[key] = [{"interval": iv} | regime_counts(b1, *iv) for iv in PAPER[key]]
    ii = np.zeros(b1["f"].size, bool)
    for iv in PAPER["b_ii"]:
        ii |= within(b1, *iv)
    fr = b1["fractions"][ii]
    out["b_ii_fractions"] = {
        "first": [float(fr[:, 0].min()), float(fr[:, 0].max())],
        "second": [float(fr[:, 1].min()), float(fr[:, 1].max())],
        "max_n_attractors": int(b1["n_attractors"][ii].max()),
        "D_main_max_abs": float(np.abs(b1["D_main"][ii]).max()),
    }
    out["c"] = regime_counts(b1, *PAPER["c"])
    d = within(b1, *PAPER["d"])
    out["d"] = regime_counts(b1, *PAPER["d"]) | {
        "ergodic": int(b1["ergodic"][d].sum()),
        "a_at": [float(f) for f in b1["f"][d & (b1["regime"] == 0)]],
        "other_at": [float(f) for f in b1["f"][d & (b1["regime"] == 5)]],
        "c_at": [float(f) for f in b1["f"][d & (b1["regime"] == 3)]],
    }
    out["b_ii_anywhere"] = int(np.sum(b1["regime"] == 2))
    b_i = b1["regime"] == 1
    out["b_i_span"] = [float(b1["f"][b_i][0]), float(b1["f"][b_i][-1])]
    out["b_i_points"] = int(b_i.sum())
    out["fractions_sum_max_dev"] = float(
        np.abs(b1["fractions"].sum(axis=1) + b1["unsettled_fraction"] - 1.0).max()
    )
    out["points"] = {str(f): point(s3, b1, f) for f in (57.0, 58.0, 62.0, 85.2, 88.4)}
    hi = within(s3, 65.8, 95.0)
    still = hi & (np.abs(s3["D"]) < 0.01)
    moving = hi & (s3["D"] > 1.0)
    out["stuck_still"] = float(np.median(s3["stuck_fraction"][still]))
    out["stuck_moving"] = float(np.median(s3["stuck_fraction"][moving]))
    out["still_points"] = int(still.sum())
    out["moving_points"] = int(moving.sum())
    return out


def locked_58(table: dict) -> dict:
    """P13, P14: the two attractors at 58 and 62 Hz (n = 1000, t = 50 s, seed 0)."""
    out = {}
    for f in (58.0, 62.0):
        rows = [r for r in table["rows"] if r["f"] == f and r["n"] == 1000]
        out[f"{f:g}"] = [
            {
                k: r[k]
                for k in ("fraction", "character", "collisions_per_period", "jumps_per_period", "D")
            }
            for r in rows
        ]
    return out


def resonance_74(b1: dict, tongue_2: list[float]) -> dict:
    """P8, P15: the attractors of the high box at 74.0 and 74.5 Hz (fresh runs), and the
    reference box's attractors in the 2/1 tongue ``tongue_2`` (Hz) (B1)."""
    runs_ = json.loads((DOCS / "data" / "classify_74_high.json").read_text())["runs"]
    m = within(b1, *tongue_2)
    out = {
        "reference_box_in_tongue": {
            "points": int(m.sum()),
            "max_attractors": int(b1["n_attractors"][m].max()),
            "locked_points": int(np.sum(b1["locking_k"][m] > 0)),
        }
    }
    for run in runs_:
        s = run["result"]
        out[f"{s['f']:g}"] = {
            "regime": s["regime"],
            "attractors": [
                {
                    "fraction": a["fraction"],
                    "members": a["members"],
                    "character": a["character"],
                    "locking_k": a["locking_k"],
                    "D": pair(a["D"], a["D_se"]),
                }
                for a in s["attractors"]
            ],
        }
    return out


def classified_85_88() -> dict:
    """docs/classification.md: the one attractor at 85.2 and 88.4 Hz (fresh runs): its
    regime, share of flights locked near the dominant k (``k_tol``) and of tiny hops."""
    runs_ = json.loads((DOCS / "data" / "classify_85_88.json").read_text())["runs"]
    out = {}
    for run in runs_:
        s = run["result"]
        (a,) = s["attractors"]
        out[f"{s['f']:g}"] = {
            "regime": s["regime"],
            "character": a["character"],
            "dominant_k": a["dominant_k"],
            "locked_fraction": a["locked_fraction"],
            "tiny_fraction": a["tiny_fraction"],
            "k_tol": s["thresholds"]["k_tol"],
            "n": s["n"],
            "t": s["t"],
        }
    return out


def orbit_88(s8: dict, s8_meta: dict, s3: dict, b1: dict) -> dict:
    """P18: rounds of the six regions at 88.4 Hz; period 11 would alternate full and skip."""
    imp = (s8["kind"] == 0) & np.isfinite(s8["flight"])
    rounds, cur = [], None
    for r in s8["region"][imp].astype(int):
        if r == 1:
            if cur is not None:
                rounds.append(tuple(cur))
            cur = [1]
        elif cur is not None:
            cur.append(r)
    kinds = [
        "full" if r == (1, 2, 3, 4, 5, 6) else "skip5" if r == (1, 2, 3, 4, 6) else "other"
        for r in rounds
    ]
    clean = [(a, b) for a, b in zip(kinds[:-1], kinds[1:], strict=True) if "other" not in (a, b)]
    return {
        "collisions": int(imp.sum()),
        "major_regions": s8_meta["key_numbers"]["major_regions"],
        "rounds": len(rounds),
        "full": kinds.count("full"),
        "skip5": kinds.count("skip5"),
        "other": kinds.count("other"),
        "pairs": len(clean),
        "alternating_pairs": sum(a != b for a, b in clean),
        "mean_flight_periods": s8_meta["key_numbers"]["mean_flight_periods"],
        "n": s8_meta["settings"]["n"],
        "transient": s8_meta["settings"]["transient"],
    } | {k: v for k, v in point(s3, b1, 88.4).items() if k in ("D", "regime")}


def random_walk(s9: dict, s3: dict, setup_: dict) -> dict:
    """P20, P21: D_rw against D, tau against d / sqrt(2 E_x), r against 19, D_a."""
    from bbdyn import Params

    p = Params(f=PAPER["f0"])  # A, g, alpha, R, d: the defaults (f does not enter)
    idx = [at(s3, f) for f in s9["f"]]
    E_x = s3["E_x"][idx]
    moving = s9["D"] > 3 * s9["D_err"]
    tau_ratio = (s9["tau"] * np.sqrt(2 * E_x) / p.d)[moving]
    r = s9["r"]
    near = np.abs(r - PAPER["r"]) <= 0.1 * PAPER["r"]
    w = 2 * np.pi * s9["f"]
    arg = (p.A * w) ** 2 / 20 - p.g * p.A / 10
    D_a_paper = np.where(arg > 0, 0.5 * p.d * np.sqrt(np.clip(arg, 0, None)), np.nan)
    m8090 = within(s9, 80.0, 90.0) & moving
    k1, k3 = setup_["tongues"][0], setup_["tongues"][2]
    in3 = within(s9, *k3)
    i85 = at(s9, 85.2)
    return {
        "f_range": [float(s9["f"][0]), float(s9["f"][-1])],
        "points": int(s9["f"].size),
        "moving": int(moving.sum()),
        "D_rw_over_D_median": float(np.median((s9["D_rw"] / s9["D"])[moving])),
        "D_rw_over_D_range": [
            float(np.min((s9["D_rw"] / s9["D"])[moving])),
            float(np.max((s9["D_rw"] / s9["D"])[moving])),
        ],
        "spearman_D_rw_D": spearman(s9["D_rw"], s9["D"]),
        "tau_sqrt2Ex_over_d": {
            "median": float(np.median(tau_ratio)),
            "min": float(tau_ratio.min()),
            "max": float(tau_ratio.max()),
        },
        "r_moving": {
            "median": float(np.median(r[moving])),
            "min": float(r[moving].min()),
            "max": float(r[moving].max()),
        },
        "r_in_k3": [float(r[in3].min()), float(r[in3].max())],
        "r_within_10pc_of_19": {"points": int(near.sum()), "runs": runs(s9["f"], near)},
        "r_above_100": [float(f) for f in s9["f"][r > 100]],
        "k1_hi": k1[1],
        "D_a_defined_from": float(s9["f"][np.isfinite(s9["D_a"])][0]),
        "slope_80_90": {
            "D_rw": slope(s9["f"][m8090], s9["D_rw"][m8090]),
            "D_a_paper": slope(s9["f"][m8090], D_a_paper[m8090]),
            "D_a": slope(s9["f"][m8090], s9["D_a"][m8090]),
            "D": slope(s9["f"][m8090], s9["D"][m8090]),
        },
        "D_a_paper_over_D_rw_80_90": float(np.median(D_a_paper[m8090] / s9["D_rw"][m8090])),
        "D_a_over_D_rw_80_90": float(np.median(s9["D_a"][m8090] / s9["D_rw"][m8090])),
        "at_85_2": {
            "D": pair(s9["D"][i85], s9["D_err"][i85]),
            "D_rw": pair(s9["D_rw"][i85], s9["D_rw_err"][i85]),
            "D_a": pair(s9["D_a"][i85], s9["D_a_err"][i85]),
            "r": pair(s9["r"][i85], s9["r_err"][i85]),
            "tau": pair(s9["tau"][i85], s9["tau_err"][i85]),
            "D_a_paper": float(D_a_paper[i85]),
        },
    }


def green_kubo(s10: dict) -> dict:
    """P22, P23: the truncated series D_n against the Einstein D on [84.6, 86.4] Hz."""
    from bbdyn import Params

    d = Params(f=PAPER["f0"]).d
    D, De = s10["D"], s10["D_err"]
    orders = {}
    for n in (0, 2, 4, 7, 10):
        Dn, Dne = s10["D_n"][:, n], s10["D_n_err"][:, n]
        ratio = Dn / D
        # spread of D_n / D over f against its statistical error (D's error dominates)
        err = ratio * np.hypot(De / D, Dne / Dn)
        orders[str(n)] = {
            "mean_ratio": float(ratio.mean()),
            "within_2se": int(np.sum(np.abs(Dn - D) <= 2 * np.hypot(De, Dne))),
            "ratio_range": [float(ratio.min()), float(ratio.max())],
            "ratio_chi2_dof": float(np.sum(((ratio - ratio.mean()) / err) ** 2) / (D.size - 1)),
        }
    i = at(s10, 85.2)
    return {
        "points": int(D.size),
        "f_range": [float(s10["f"][0]), float(s10["f"][-1])],
        "D_range": [float(D.min()), float(D.max())],
        "orders": orders,
        "D_0_identity_max_rel": float(
            np.max(np.abs(s10["D_n"][:, 0] - d**2 / (2 * s10["tau"])) / s10["D_n"][:, 0])
        ),
        "p_f": [float(s10["p_f"].min()), float(s10["p_f"].max())],
        "p_b": [float(s10["p_b"].min()), float(s10["p_b"].max())],
        "at_85_2": {
            "D": pair(D[i], De[i]),
            "p_f": float(s10["p_f"][i]),
            "tau": float(s10["tau"][i]),
        }
        | {f"D_{n}": pair(s10["D_n"][i, n], s10["D_n_err"][i, n]) for n in (0, 2, 4, 7, 10)},
    }


def results_70(s3: dict, b1: dict) -> dict:
    """docs/results.md: two neighbouring frequencies in different states."""
    return {f"{f:g}": point(s3, b1, f) for f in (70.0, 70.2)}


def d_max(s3: dict) -> dict:
    i = int(np.argmax(s3["D"]))
    j = int(np.argmax(s3["E_x"]))
    moving = s3["D"] > 3 * s3["D_err"]
    return {
        "D": pair(s3["D"][i], s3["D_err"][i]),
        "f": float(s3["f"][i]),
        "rel_err_median": float(np.median(s3["D_err"][moving] / s3["D"][moving])),
        "moving_points": int(moving.sum()),
        "E_x": pair(s3["E_x"][j], s3["E_x_err"][j]),
        "f_E_x": float(s3["f"][j]),
    }


def provenance() -> dict:
    from bbdyn import __version__

    inputs = {}
    for name in FIGURES:
        meta = json.loads((DOCS / "figures" / f"{name}.json").read_text())["meta"]
        inputs[f"figures/{name}"] = {
            "npz_sha256": sha256(DOCS / "figures" / f"{name}.npz"),
            "json_sha256": sha256(DOCS / "figures" / f"{name}.json"),
            "made_at_commit": meta["provenance"]["commit"],
        }
    for path in [D_TABLE] + [DOCS / "data" / name for name in FRESH]:
        inputs[path.relative_to(DOCS).as_posix()] = {"sha256": sha256(path)}
    return {
        "command": "python docs/data/paper_numbers.py",
        "bbdyn_version": __version__,
        "inputs": inputs,
    }


def build() -> dict:
    """Every number of the pages, from the committed inputs (no simulation)."""
    s1, s1_meta = load("S1")
    _, s2_meta = load("S2")
    s3, s3_meta = load("S3_full")
    s8, s8_meta = load("S8")
    s9, _ = load("S9_full")
    s10, _ = load("S10_full")
    b1, _ = load("B1_full")
    assert np.allclose(s3["f"], b1["f"]), "S3_full and B1_full are on different grids"
    table = json.loads(D_TABLE.read_text())
    setup_ = setup(s2_meta, s1_meta)
    return {
        "provenance": provenance(),
        "scan": {
            "n": s3_meta["settings"]["n"],
            "t": s3_meta["settings"]["t"],
            "points": int(s3["f"].size),
            "D_not_converged": runs(s3["f"], s3["D_converged"] == 0),
            "D_not_converged_below_54": runs(s3["f"], (s3["D_converged"] == 0) & (s3["f"] < 54)),
            "energy_not_stationary": runs(s3["f"], s3["energy_stationary"] == 0),
            "cpu_s": s3_meta["scan_cpu_s"],
        },
        "setup": setup_,
        "onset": onset(s3, b1),
        "D_70_80": d_70_80(s3, b1, setup_),
        "D_max": d_max(s3),
        "peak_77": peak_77(s3, setup_["h"]),
        "energy": energies(s3),
        "regimes": regimes(s3, b1),
        "attractors_58_62": locked_58(table),
        "resonance_74": resonance_74(b1, setup_["tongues"][1]),
        "orbit_88": orbit_88(s8, s8_meta, s3, b1),
        "classified_85_88": classified_85_88(),
        "random_walk": random_walk(s9, s3, setup_),
        "green_kubo": green_kubo(s10),
        "results_70": results_70(s3, b1),
    }


def fresh() -> None:
    """Rerun the small runs of ``FRESH`` and store each output with its command."""
    for name, commands in FRESH.items():
        out = []
        for argv in commands:
            text = subprocess.run(
                [sys.executable, "-m", "bbdyn", *argv],
                check=True,
                capture_output=True,
                text=True,
                cwd=ROOT,
            ).stdout
            result = json.loads(text)
            result.pop("wall_s", None)
            result.pop("feature_wall_s", None)
            out.append({"command": "bbdyn " + " ".join(argv), "result": result})
        (DOCS / "data" / name).write_text(json.dumps({"runs": out}, indent=1) + "\n")


def dumps(data: dict) -> str:
    return json.dumps(data, indent=1) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fresh", action="store_true", help="rerun the runs of FRESH first")
    args = parser.parse_args()
    if args.fresh:
        fresh()
    OUT.write_text(dumps(build()), encoding="utf-8")
    print(f"wrote {OUT.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
