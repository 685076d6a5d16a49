"""Two full D(f) scans compared point by point, in units of their combined standard errors.

For every frequency both scans computed, and for D, E and E_x,

    z = (new - old) / sqrt(err_new^2 + err_old^2),

which for two independent runs of the same physics is close to a standard normal variable
(the scans share seeds; chaotic trajectories that differ by a rounding decorrelate within a
few driving periods, so there they are independent samples, while trapped and periodic
points repeat).  Where every particle ends on one periodic orbit the error over particles
is itself at the level of rounding (E_err / E ~ 1e-16) and z says nothing: an energy
difference within twice the rounding bound of the energy averages
(``bbdyn.scans.frequency.average_rounding``, with the events per particle) counts as
agreement (z = 0) and is reported.  Points where both errors are zero (trapped: D = 0
exactly) count as z = 0 if the values agree and are reported otherwise.  Prints, per
quantity, the fraction of points with |z| > 3 (0.27 % for a standard normal), the mean and
standard deviation of z and chi^2 / dof; draws z against f and its histogram against the
standard normal density, and saves the figure with the numbers beside it (``.json``).
The PNG records the git state of the tree that ran the comparison and both inputs.

Usage::

    bbdyn scan --f-start 49.8 --f-stop 95 --f-step 0.2 --n 1000 --t 200 --out SCAN --json > new.json
    python benchmarks/scan_compare.py docs/figures/S3_full.npz new.json --out OUT.png
"""

import argparse
import json
import math
from pathlib import Path

import numpy as np

QUANTITIES = (("D", "D_err", "D_se"), ("E", "E_err", "E_se"), ("E_x", "E_x_err", "E_x_se"))
#: |z| beyond which a point is counted as an outlier
Z_OUT = 3.0


def load_old(path: Path) -> dict[str, np.ndarray]:
    """f, the (value, error) arrays and the rounding bounds (``rounding_bounds``) of a saved
    S3 scene (``.npz`` with its ``.json``)."""
    meta = json.loads(path.with_suffix(".json").read_text())["meta"]
    with np.load(path) as z:
        out = {k: np.asarray(z[k], float) for k in ("f", *(n for q in QUANTITIES for n in q[:2]))}
        events = np.asarray(z["events"], float) / meta["settings"]["n"]
    out.update(rounding_bounds(out, events, meta["params"]["g"], meta["params"]["A"]))
    return out


def rounding_bounds(scan: dict, events: np.ndarray, g: float, A: float) -> dict:
    """Bounds of the rounding of the energy averages of ``scan`` (same units), from the
    events per particle (``bbdyn.scans.frequency.average_rounding``); D has none."""
    from bbdyn.scans.frequency import average_rounding, energy_scale

    return {"D_round": np.zeros_like(events),
            "E_round": average_rounding(events, energy_scale(scan["E"], g, A)),
            "E_x_round": average_rounding(events, scan["E_x"])}  # fmt: skip


def load_new(path: Path) -> dict[str, np.ndarray]:
    """f and the (value, error) arrays of ``bbdyn scan --json`` output."""
    points = json.loads(Path(path).read_text())["points"]
    out = {"f": np.array([p["f"] for p in points], float)}
    for name, err, se in QUANTITIES:
        out[name] = np.array([p[name] for p in points], float)
        out[err] = np.array([p[se] for p in points], float)
    return out


def z_scores(old: dict, new: dict) -> dict:
    """Per quantity: the common frequencies, z, and the summary numbers (module docstring)."""
    f_old, f_new = np.round(old["f"], 9), np.round(new["f"], 9)
    common, i_old, i_new = np.intersect1d(f_old, f_new, return_indices=True)
    out = {"f": common, "n_points": int(common.size)}
    for name, err, _ in QUANTITIES:
        diff = new[name][i_new] - old[name][i_old]
        sigma = np.hypot(new[err][i_new], old[err][i_old])
        # both averages within the bound of the same size: a difference within twice it
        rounding = np.abs(diff) <= 2.0 * old[name + "_round"][i_old]
        exact = (sigma == 0.0) | rounding
        z = np.where(exact, 0.0, diff / np.where(exact, 1.0, sigma))
        disagree_exact = (sigma == 0.0) & (diff != 0.0)
        free = z[~exact] if np.sum(~exact) > 1 else np.full(2, math.nan)  # nan: too few
        out[name] = {
            "z": z,
            "beyond_3": float(np.mean(np.abs(z) > Z_OUT)),
            "n_beyond_3": int(np.sum(np.abs(z) > Z_OUT)),
            "mean_z": float(free.mean()),
            "std_z": float(free.std(ddof=1)),
            "chi2_per_dof": float(np.mean(free**2)),
            "n_exact": int(exact.sum()),
            "exact_disagree_f": common[disagree_exact].tolist(),
            "within_rounding_f": common[rounding & (diff != 0.0)].tolist(),
            "max_rel_diff_within_rounding": float(
                np.max(np.abs(diff)[rounding & (diff != 0.0)] / np.abs(new[name][i_new])[
                    rounding & (diff != 0.0)], initial=0.0)
            ),
        }
    return out


def draw(result: dict, title: str):
    """z against f (one row per quantity) and the histograms of z against N(0, 1)."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(3, 2, figsize=(11, 8), gridspec_kw={"width_ratios": [3, 1]})
    grid = np.linspace(-5, 5, 201)
    for row, (name, _, _) in zip(axes, QUANTITIES, strict=True):
        q = result[name]
        row[0].plot(result["f"], q["z"], ".", ms=3)
        for level in (-Z_OUT, Z_OUT):
            row[0].axhline(level, color="0.6", lw=0.8, ls="--")
        row[0].set_ylabel(f"z({name})")
        row[1].hist(np.clip(q["z"], -5, 5), bins=40, range=(-5, 5), density=True, alpha=0.6)
        row[1].plot(grid, np.exp(-grid**2 / 2) / math.sqrt(2 * math.pi), "k-", lw=1)
        row[1].set_title(
            f"|z|>3: {q['n_beyond_3']}/{result['n_points']}; chi2/dof {q['chi2_per_dof']:.2f}",
            fontsize=8,
        )
    axes[-1, 0].set_xlabel("f (Hz)")
    axes[-1, 1].set_xlabel("z")
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    return fig


def doc_table(summary: dict) -> str:
    """The table of a comparison's JSON (``summary``) as docs/benchmarks.md shows it."""
    rows = ["| quantity | points with abs(z) > 3 | mean z | std z | chi^2 / dof | z = 0 |",
            "|---|---:|---:|---:|---:|---:|"]  # fmt: skip
    for name, _, _ in QUANTITIES:
        q = summary[name]
        rows.append(f"| {name} | {q['n_beyond_3']} of {summary['n_points']} | {q['mean_z']:+.3f} "
                    f"| {q['std_z']:.3f} | {q['chi2_per_dof']:.3f} | {q['n_exact']} |")  # fmt: skip
    return "\n".join(rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("old", type=Path, help="saved S3 scene (.npz)")
    parser.add_argument("new", type=Path, help="JSON output of bbdyn scan --json")
    parser.add_argument("--out", type=Path, required=True, help="figure path (.png)")
    parser.add_argument("--title", default="new scan - previous scan, in combined errors")
    args = parser.parse_args()

    from bbdyn.scenes import save_figure, source_state

    result = z_scores(load_old(args.old), load_new(args.new))
    for name, _, _ in QUANTITIES:
        q = result[name]
        print(f"{name}: {result['n_points']} points, |z| > 3 at {q['n_beyond_3']} "
              f"({100 * q['beyond_3']:.2f} %), mean z {q['mean_z']:+.3f}, "
              f"std z {q['std_z']:.3f}, chi2/dof {q['chi2_per_dof']:.3f}; z = 0: "
              f"{q['n_exact']} (both errors 0 and differing: {q['exact_disagree_f']}; "
              f"different within the rounding bound: {q['within_rounding_f']}, largest "
              f"relative difference {q['max_rel_diff_within_rounding']:.1e})")  # fmt: skip
    old_meta = json.loads(args.old.with_suffix(".json").read_text())["meta"].get("provenance", {})
    prov = {
        "command": "python benchmarks/scan_compare.py " + f"{args.old} {args.new} --out {args.out}",
        "compared_by": source_state(),
        "old": {"file": str(args.old), "commit": old_meta.get("commit")},
        "new": {"file": str(args.new)},
    }
    save_figure(draw(result, args.title), args.out, prov)
    summary = {q: {k: v for k, v in result[q].items() if k != "z"} for q, _, _ in QUANTITIES}
    args.out.with_suffix(".json").write_text(
        json.dumps({"provenance": prov, "n_points": result["n_points"], **summary}, indent=1)
    )
    print(doc_table(json.loads(args.out.with_suffix(".json").read_text())))
    print(f"saved {args.out} and {args.out.with_suffix('.json')}")


if __name__ == "__main__":
    main()
