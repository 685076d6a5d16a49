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


def benchmarks_page():
    """docs/benchmarks.md's text, its words joined by single spaces, and a loader of the JSON
    files of docs/scan_compare by name."""
    folder = ROOT / "docs" / "scan_compare"
    text = (ROOT / "docs" / "benchmarks.md").read_text()
    return text, " ".join(text.split()), lambda name: json.loads((folder / name).read_text())


def bench_file(name: str) -> dict:
    """A committed benchmark report of docs/bench by name."""
    return json.loads((ROOT / "docs" / "bench" / name).read_text())


def timed_scans(load, commits, flat: str) -> dict:
    """``{commit: (scan, wall)}``, the committed full scans and their wall times; checks that
    docs/benchmarks.md (``flat``) states each one's wall and CPU time."""
    scans = {}
    for commit in commits:
        scan, wall = load(f"full_scan_{commit}.json"), load(f"full_scan_{commit}_wall.json")
        assert wall["scan"] == f"docs/scan_compare/full_scan_{commit}.json"
        timing = f"{wall['wall_s']:.0f} s wall and {scan['cpu_s']:.0f} s of CPU time at {commit}"
        assert timing in flat
        scans[commit] = (scan, wall)
    return scans


def test_the_docs_table_is_the_committed_comparison():
    """docs/benchmarks.md shows the table of docs/scan_compare/full_scan_compare.json, which
    compares the committed full scan with docs/figures/S3_full (recomputed here), where that
    scan's time went, its speed-up over the db5ef1b and c98c783 scans and the kernel
    benchmark beside it."""

    m = _module()
    root = ROOT
    from bbdyn.scenes.b2_scan_cost import measured_speedup_table, measured_table

    folder = root / "docs" / "scan_compare"
    saved = json.loads((folder / "full_scan_compare.json").read_text())
    text = (root / "docs" / "benchmarks.md").read_text()
    flat = " ".join(text.split())
    assert m.doc_table(saved) in text
    scan = json.loads((root / saved["provenance"]["new"]["file"]).read_text())
    assert measured_table(scan["points"]) in text
    assert f"{scan['cpu_s']:.0f} s of CPU time" in flat
    wall = json.loads((folder / "full_scan_7c21b69_wall.json").read_text())
    assert wall["scan"] == saved["provenance"]["new"]["file"]
    assert f"{wall['wall_s']:.0f} s wall" in flat
    assert f"{wall['wall_s']:.0f} s is {wall['wall_s'] / 600:.1f} times too long" in flat
    for commit in ("db5ef1b", "c98c783"):
        before = json.loads((folder / f"full_scan_{commit}.json").read_text())
        assert measured_speedup_table(before["points"], scan["points"]) in text
    previous = json.loads((folder / "full_scan_c98c783.json").read_text())
    previous_wall = json.loads((folder / "full_scan_c98c783_wall.json").read_text())
    assert f"{previous_wall['wall_s']:.0f} s wall" in flat
    kernel = json.loads((folder / "kernel_buffers_c98c783_7c21b69.json").read_text())
    assert load_benchmark("kernel_buffers").doc_table(kernel) in text
    # "the whole scan gained a little more (1.23) than the kernel at these sample frequencies"
    gain = previous["cpu_s"] / scan["cpu_s"]
    assert f"a little more ({gain:.2f}) than the kernel" in flat
    assert gain > max(row["ratio"] for row in kernel["results"])
    old = m.load_old(root / "docs" / "figures" / "S3_full.npz")
    new = m.load_new(root / saved["provenance"]["new"]["file"])
    again = m.z_scores(old, new)
    f = again["f"]
    for name in ("D", "E", "E_x"):
        assert {k: v for k, v in again[name].items() if k != "z"} == saved[name]
        # the sentences under the table: below 57 Hz the energies agree to rounding and D
        # within 1.1; the energies within 1 up to 65 Hz; noise above 65 Hz
        z = again[name]["z"]
        assert np.abs(z[f < 57.0]).max() < (1.1 if name == "D" else 1e-4)
        if name != "D":
            assert np.abs(z[f < 65.0]).max() < 1.0
        assert 0.8 < z[f > 65.0].std(ddof=1) < 1.2
    # D already scatters between 57 and 65 Hz
    assert np.abs(again["D"]["z"][(f > 57.0) & (f < 65.0)]).max() > 1.0


def test_the_scan_with_converged_cycles_fast_forwarded():
    """docs/benchmarks.md on the full scan at 323a012 (converged cycles fast-forwarded): its
    wall and CPU time, where the time went, the speed-up over 7c21b69 band by band, and how
    it differs from that scan (the same kernel and seeds) point by point."""

    from bbdyn.scenes.b2_scan_cost import agreement_sentence, measured_speedup_table, measured_table

    folder = ROOT / "docs" / "scan_compare"
    flat = " ".join((ROOT / "docs" / "benchmarks.md").read_text().split())
    scan = json.loads((folder / "full_scan_323a012.json").read_text())
    wall = json.loads((folder / "full_scan_323a012_wall.json").read_text())
    before = json.loads((folder / "full_scan_7c21b69.json").read_text())
    assert wall["scan"] == "docs/scan_compare/full_scan_323a012.json"
    assert " ".join(measured_table(scan["points"]).split()) in flat
    assert " ".join(measured_speedup_table(before["points"], scan["points"]).split()) in flat
    assert f"{wall['wall_s']:.0f} s wall and {scan['cpu_s']:.0f} s of CPU time" in flat
    assert f"{wall['wall_s']:.0f} s is {wall['wall_s'] / 600:.2f} times the goal" in flat
    assert agreement_sentence(before["points"], scan["points"]) in flat
    # the largest saving, point by point
    old = {p["f"]: p["cpu_s"] for p in before["points"]}
    new = {p["f"]: p["cpu_s"] for p in scan["points"]}
    f = max(old, key=lambda k: old[k] - new[k])
    assert f == max(old, key=old.get)  # the costliest point before
    assert f"{f:g} Hz, the costliest point of the 7c21b69 scan, went from {old[f]:.1f} s to" in flat
    assert f"to {new[f]:.1f} s" in flat
    assert f"The route is worth about {100 * (1 - scan['cpu_s'] / before['cpu_s']):.0f} %" in flat
    assert f"({wall['wall_s']:.0f} s now, {wall['wall_s'] / 600:.2f} times too long)" in flat


def test_the_scan_with_newton_from_the_quadratic_root():
    """docs/benchmarks.md on 2813441: the interleaved kernel and bench runs, the full scan's
    times against 323a012 (compilation, fast-forward luck, the machine's drift) and its
    agreement with S3_full, every number from the committed files."""

    from bbdyn.scenes.b2_scan_cost import measured_speedup_table

    m = load_benchmark("scan_compare")
    text, flat, load = benchmarks_page()
    new, old = load("full_scan_2813441.json"), load("full_scan_323a012.json")
    wall = load("full_scan_2813441_wall.json")
    assert wall["scan"] == "docs/scan_compare/full_scan_2813441.json"
    assert f"{wall['wall_s']:.0f} s wall and {new['cpu_s']:.0f} s of CPU time" in flat
    assert f"the scan took {wall['wall_s'] / 60:.0f} minutes on this machine" in flat
    assert measured_speedup_table(old["points"], new["points"]) in text
    kernel = load("kernel_buffers_323a012_3b612d9.json")
    assert load_benchmark("kernel_buffers").doc_table(kernel) in text
    ratios = [r["ratio"] for r in kernel["results"]]
    assert f"hide the {100 * (min(ratios) - 1):.0f}-{100 * (max(ratios) - 1):.0f} % of" in flat
    bench = bench_file("bench_trees_356ac1d_2813441.json")
    trees = load_benchmark("bench_trees")
    for target in ("flat", "billiard"):
        assert trees.doc_table(bench, target) in text
    assert bench["flat"][0]["ratio"] < 1.0  # "the flat ball does not gain"
    assert_targets_out_of_reach(bench, "2813441", flat)
    # the compilation in the first point of each worker, and the rest of the scan
    o = {p["f"]: p["cpu_s"] for p in old["points"]}
    n = {p["f"]: p["cpu_s"] for p in new["points"]}
    assert (f"took {n[49.8]:.1f} and {n[50.0]:.1f} s against {o[49.8]:.1f} and {o[50.0]:.1f} s "
            "with a warm cache") in flat  # fmt: skip
    rest = [sum(v for f, v in d.items() if f not in (49.8, 50.0)) for d in (n, o)]
    assert rest[0] > rest[1]  # "not faster"
    assert f"the scan took {rest[0]:.0f} s of CPU time against {rest[1]:.0f} s: not faster" in flat
    assert (f"70.2 Hz took {n[70.2]:.1f} s against {o[70.2]:.1f} s, "
            f"63 Hz {n[63.0]:.1f} s against {o[63.0]:.1f} s") in flat  # fmt: skip
    # the machine's drift: 323a012's kernel rerun on the day of this scan, the same numbers
    drift = load("day_drift_323a012.json")
    before = {p["f"]: p for p in old["points"]}
    warm = [p for p in drift["points"] if p["f"] in (70.4, 70.6, 85.4, 85.6)]
    assert len(warm) == 4
    for p in drift["points"]:
        assert all(p[k] == before[p["f"]][k] for k in ("D", "E", "E_x"))
    r = [p["cpu_s"] / before[p["f"]]["cpu_s"] for p in warm]
    assert f"took {min(r):.3f} to {max(r):.3f} times as long" in flat
    # agreement with S3_full
    beyond = agreement_with_s3_full(m, "2813441", text)
    assert [(name, x) for name, x, _ in beyond] == [("E", 73.0)]
    assert f"(E at 73 Hz, z = {beyond[0][2]:.1f})" in flat


def test_the_scan_with_one_evaluation_fewer_above_the_floor():
    """docs/benchmarks.md on 310c13d and cc2e660: the interleaved kernel and bench runs against
    187c778, both full scans against 2813441 and cc2e660's agreement with S3_full, every
    number from the committed files."""

    from bbdyn.scenes.b2_scan_cost import measured_speedup_table

    m = load_benchmark("scan_compare")
    text, flat, load = benchmarks_page()
    before = load("full_scan_2813441.json")
    scans = timed_scans(load, ("310c13d", "cc2e660"), flat)
    for scan, _ in scans.values():
        assert measured_speedup_table(before["points"], scan["points"]) in text
        assert scan["cpu_s"] < before["cpu_s"]
    wall = scans["cc2e660"][1]
    assert f"the scan took {wall['wall_s'] / 60:.0f} minutes on this machine" in flat
    assert wall["wall_s"] > 600  # "the 10-minute goal was not reached"
    kernel = load("kernel_buffers_187c778_cc2e660.json")
    assert kernel["trees"] == ["187c778", "cc2e660"]
    assert load_benchmark("kernel_buffers").doc_table(kernel) in text
    ratios = {r["f"]: r["ratio"] for r in kernel["results"]}
    assert ratios[90.0] > ratios[50.2]  # "the gain grows with the frequency"
    bench = bench_file("bench_trees_187c778_cc2e660.json")
    trees = load_benchmark("bench_trees")
    for target in ("flat", "billiard"):
        assert trees.doc_table(bench, target) in text
    assert all(row["ratio"] > 1.0 for row in bench["billiard"])  # "the billiard gains"
    assert bench["billiard"][1]["ratio"] == max(row["ratio"] for row in bench["billiard"])
    loose = [row["ratio"] for row in bench["flat"] if row["setting"].startswith("step_rel")]
    slower = f"{100 * (1 - max(loose)):.0f}-{100 * (1 - min(loose)):.0f} % slower"
    assert f"loose tolerances ran {slower} after the change" in flat
    assert_targets_out_of_reach(bench, "cc2e660", flat)
    # agreement with S3_full
    beyond = agreement_with_s3_full(m, "cc2e660", text)
    assert [(name, x) for name, x, _ in beyond] == [("E", 77.8), ("E_x", 91.0)]
    values = 3 * len(load("full_scan_cc2e660.json")["points"])  # D, E and E_x at each f
    assert f"Two points in {values} lie beyond 3 combined standard errors" in flat
    assert f"(0.27 % of {values} is {0.0027 * values:.1f})" in flat
    assert (f"(E at 77.8 Hz, z = {beyond[0][2]:.2f}, and E_x at 91 Hz, z = {beyond[1][2]:.2f})"
            in flat)  # fmt: skip


def bench_speeds(bench: dict, commit: str) -> tuple[float, float, float]:
    """Speeds of ``commit`` in a bench_trees report against the targets: flat impacts/s at
    the default tolerance, billiard collisions/s in one flight and in a continuous run."""
    return tuple(bench[t][i][commit]["speed"] for t, i in (("flat", 0), ("billiard", 0),
                                                           ("billiard", 1)))  # fmt: skip


def assert_targets_out_of_reach(bench: dict, commit: str, flat: str) -> None:
    """The flat and billiard speeds of ``commit`` in a bench_trees report are below their
    targets, and docs/benchmarks.md (``flat``: its words joined by single spaces) says so."""
    speeds = bench_speeds(bench, commit)
    assert speeds[0] < 1e7 and max(speeds[1:]) < 8e6
    assert (
        "out of reach: {:.3g} impacts/s against 1e7 for the flat ball, {:.3g} collisions/s "
        "for one billiard flight and {:.3g} in a continuous run".format(*speeds)
    ) in flat


#: D (mm^2/s) below which a scan point's D is zero to the rounding of its positions.
D_ZERO = 1e-15


def agreement_with_s3_full(m, commit: str, text: str) -> list[tuple[str, float, float]]:
    """The full scan at ``commit`` against docs/figures/S3_full, recomputed: the same numbers
    as its saved comparison and docs/benchmarks.md's table, energies equal to rounding
    below 57 Hz; returns the points beyond 3 combined standard errors, (quantity, f, z)."""
    folder = ROOT / "docs" / "scan_compare"
    saved = json.loads((folder / f"full_scan_compare_{commit}.json").read_text())
    assert m.doc_table(saved) in text
    old = m.load_old(ROOT / "docs" / "figures" / "S3_full.npz")
    new = m.load_new(folder / f"full_scan_{commit}.json")
    again = m.z_scores(old, new)
    f = again["f"]
    # D zero to the rounding of positions in both scans: every particle locked, z is noise
    # about noise (docs/benchmarks.md, 2dcadef), not a measure of agreement
    zero = [np.round(s["f"][np.abs(s["D"]) < D_ZERO], 9) for s in (old, new)]
    locked = np.isin(np.round(f, 9), np.intersect1d(*zero))
    for name in ("D", "E", "E_x"):
        assert {k: v for k, v in again[name].items() if k != "z"} == saved[name]
        below = (f < 57.0) & ~locked if name == "D" else f < 57.0
        assert np.abs(again[name]["z"][below]).max() < (1.1 if name == "D" else 1e-4)
    return [(name, x, z) for name in ("D", "E", "E_x")
            for x, z in zip(f, again[name]["z"], strict=True) if abs(z) > 3]  # fmt: skip


def test_the_scan_with_the_event_search_inlined():
    """docs/benchmarks.md on 0a7a3bb, e87951b and 92c6887: the interleaved kernel and bench
    runs against 8ff7342, the three full scans, 92c6887's against cc2e660 and S3_full, every
    number from the committed files."""

    from bbdyn.scenes.b2_scan_cost import measured_speedup_table, measured_table

    m = load_benchmark("scan_compare")
    text, flat, load = benchmarks_page()
    scans = timed_scans(load, ("0a7a3bb", "e87951b", "92c6887"), flat)
    cpu = [scans[c][0]["cpu_s"] for c in ("0a7a3bb", "e87951b", "92c6887")]
    assert cpu == sorted(cpu, reverse=True)
    first = {c: scans[c][0]["points"][0] for c in ("0a7a3bb", "e87951b")}
    assert all(p["f"] == 49.8 and p["trapped"] for p in first.values())
    assert (f"took {first['0a7a3bb']['cpu_s']:.1f} s at 0a7a3bb and "
            f"{first['e87951b']['cpu_s']:.1f} s at e87951b") in flat  # fmt: skip
    assert first["e87951b"]["cpu_s"] < first["0a7a3bb"]["cpu_s"]
    final, wall = scans["92c6887"]
    assert measured_table(final["points"]) in text
    assert measured_speedup_table(load("full_scan_cc2e660.json")["points"], final["points"]) in text
    # bitwise the same numbers as e87951b
    keys = ("D", "D_se", "E", "E_se", "E_x", "E_x_se", "events")
    assert all(p[k] == q[k] for p, q in zip(final["points"], scans["e87951b"][0]["points"],
                                           strict=True) for k in keys)  # fmt: skip
    kernel = load("kernel_buffers_8ff7342_92c6887.json")
    assert kernel["trees"] == ["8ff7342", "92c6887"]
    assert load_benchmark("kernel_buffers").doc_table(kernel) in text
    ratios = {r["f"]: r["ratio"] for r in kernel["results"]}
    assert max(ratios, key=ratios.get) <= 60.0 and min(ratios, key=ratios.get) == 90.0
    bench = bench_file("bench_trees_8ff7342_92c6887.json")
    trees = load_benchmark("bench_trees")
    for target in ("flat", "billiard"):
        assert trees.doc_table(bench, target) in text
        assert all(row["ratio"] > 1.0 for row in bench[target])  # "both gain"
    flat_s, one_s, run_s = bench_speeds(bench, "92c6887")
    assert max(r["ratio"] for r in bench["billiard"]) > max(r["ratio"] for r in bench["flat"])
    assert one_s > 8e6 and flat_s < 1e7 and run_s < 8e6
    assert (
        f"One billiard flight now runs at {one_s:.3g} collisions/s, above "
        f"the target of 8e6. The flat ball reaches {flat_s:.3g} impacts/s against "
        f"1e7, and a continuous billiard run {run_s:.3g} collisions/s"
    ) in flat
    last = bench_file("bench_trees_187c778_cc2e660.json")
    assert (f"in this run 8ff7342 made {bench_speeds(bench, '8ff7342')[1]:.3g} collisions/s in one "
            f"flight, where cc2e660, the same kernel, made "
            f"{last['billiard'][0]['cc2e660']['speed']:.3g}") in flat  # fmt: skip
    # agreement with S3_full
    beyond = agreement_with_s3_full(m, "92c6887", text)
    assert [(name, x) for name, x, _ in beyond] == [("E_x", 91.0)]
    values = 3 * len(final["points"])
    assert f"One point in {values} lies beyond 3 combined standard errors" in flat
    assert f"(E_x at 91 Hz, z = {beyond[0][2]:.2f})" in flat
    over = wall["wall_s"] - 600
    assert (
        0 < over
        and (
            f"The 10-minute goal was missed by {over:.0f} s: the scan took "
            f"{wall['wall_s']:.0f} s, {wall['wall_s'] / 60:.1f} minutes"
        )
        in flat
    )


def test_the_scan_with_a_square_root_fewer_per_falling_step():
    """docs/benchmarks.md on 0e2c1d6 and 67c51b6: both full scans, the interleaved kernel and
    bench runs of 67c51b6 against 92c6887, its scan against 92c6887's and S3_full, every
    number from the committed files."""

    from bbdyn.scenes.b2_scan_cost import measured_speedup_table, measured_table

    m = load_benchmark("scan_compare")
    text, flat, load = benchmarks_page()
    before = load("full_scan_92c6887.json")
    before_wall = load("full_scan_92c6887_wall.json")
    scans = timed_scans(load, ("0e2c1d6", "67c51b6"), flat)
    # "no gain at the scale of a scan": 0e2c1d6 within 1 % of 92c6887's CPU time
    assert abs(scans["0e2c1d6"][0]["cpu_s"] / before["cpu_s"] - 1) < 0.01
    assert (f"against {before_wall['wall_s']:.0f} s and {before['cpu_s']:.0f} s at 92c6887"
            in flat)  # fmt: skip
    final, wall = scans["67c51b6"]
    assert measured_table(final["points"]) in text
    assert measured_speedup_table(before["points"], final["points"]) in text
    kernel = load("kernel_buffers_92c6887_67c51b6.json")
    assert kernel["trees"] == ["92c6887", "67c51b6"]
    assert load_benchmark("kernel_buffers").doc_table(kernel) in text
    ratios = [row["ratio"] for row in kernel["results"]]
    assert f"The kernel gains {min(ratios):.2f}-{max(ratios):.2f} at every frequency" in flat
    assert min(ratios) > 1.0
    bench = bench_file("bench_trees_92c6887_67c51b6.json")
    trees = load_benchmark("bench_trees")
    for target in ("flat", "billiard"):
        assert trees.doc_table(bench, target) in text
        assert all(row["ratio"] > 1.0 for row in bench[target])  # "everything gains"
    flat_ratios = {row["setting"]: row["ratio"] for row in bench["flat"]}
    default = next(s for s in flat_ratios if s.startswith("default"))
    assert flat_ratios[default] == min(flat_ratios.values())  # "gains least at the default"
    for target in ("flat", "billiard"):  # "at the default tolerance ... the time errors not at all"
        row = bench[target][0]
        assert row["92c6887"]["max_time_error_s"] == row["67c51b6"]["max_time_error_s"]
        velocity = [row[c]["max_velocity_error"] for c in ("92c6887", "67c51b6")]
        assert max(velocity) < 1e-12 and max(velocity) < 1.2 * min(velocity)
    loose = [r for s, r in flat_ratios.items() if s.startswith("step_rel")]
    assert max(loose) == max(flat_ratios.values())  # "and most at the loose tolerances"
    one, cont, ens = (row["ratio"] for row in bench["billiard"])
    assert (f"One billiard flight gains {one:.3f}, the continuous run and the ensemble "
            f"{min(cont, ens):.3f}-{max(cont, ens):.3f}") in flat  # fmt: skip
    flat_s, one_s, run_s = bench_speeds(bench, "67c51b6")
    assert flat_s < 1e7 and run_s < 8e6 and one_s > 8e6
    assert (
        f"{flat_s:.3g} impacts/s against 1e7 for the flat ball, and "
        f"{run_s:.3g} collisions/s against 8e6 for a continuous billiard run "
        f"(one flight: {one_s:.3g})"
    ) in flat
    last = bench_file("bench_trees_8ff7342_92c6887.json")
    assert (
        f"The same 92c6887 made {bench_speeds(bench, '92c6887')[0]:.3g} impacts/s here against "
        f"{last['flat'][0]['92c6887']['speed']:.3g} in the run of the last section"
    ) in flat
    # the Lyapunov exponents before and after, in combined standard errors
    lyap = bench_file("lyapunov_0e2c1d6_67c51b6.json")
    assert lyap["trees"] == ["0e2c1d6", "67c51b6"]
    z = {}
    for g in lyap["groups"]:
        a, b = g["0e2c1d6"], g["67c51b6"]
        z[g["run"], g["f"], g["group"]] = abs(b["lam1_per_s"] - a["lam1_per_s"]) / math.hypot(
            a["lam1_per_s_se"], b["lam1_per_s_se"]
        )
    short = [z["short", f, "all"] for f in (70.0, 85.2, 88.4)]
    assert (
        "the billiard's exponents move by {:.2f} (70 Hz), {:.2f} (85.2 Hz) and {:.2f} "
        "(88.4 Hz) in the short runs".format(*short)
    ) in flat
    assert f"by at most {max(v for k, v in z.items() if k[0] == 'long'):.2f} in the long" in flat
    locked = next(g for g in lyap["groups"] if g["run"] == "short" and "locked" in g["group"])
    name = locked["group"]
    assert (f"The short run's locked attractor at 58 Hz moves by {z['short', 58.0, name]:.1f}, "
            f"from {locked['0e2c1d6']['lam1_per_s']:.4f} to {locked['67c51b6']['lam1_per_s']:.4f} "
            f"per second") in flat  # fmt: skip
    assert f"the same exponent moves by {z['long', 58.0, name]:.2f}" in flat
    assert max(v for k, v in z.items() if k[2] != locked["group"]) < 2.0
    # the locked attractor's share in docs/lyapunov.md's short (n 20) and long (n 100) tables
    lyapunov_md = (ROOT / "docs" / "lyapunov.md").read_text()
    shares = [float(line.split("|")[4]) for line in lyapunov_md.splitlines()
              if line.startswith("| 58 | b(i) | 1: locked |")]  # fmt: skip
    short_n, long_n = round(shares[0] * 20), round(shares[1] * 100)
    assert f"only {short_n} particles ({shares[0]:.2f} of 20)" in flat
    assert f"in the long run ({long_n} particles)" in flat
    # agreement with S3_full
    beyond = agreement_with_s3_full(m, "67c51b6", text)
    assert [(name, x) for name, x, _ in beyond] == [("D", 63.0)]
    values = 3 * len(final["points"])
    assert f"One point in {values} lies beyond 3 combined standard errors" in flat
    assert f"(D at 63 Hz, z = {beyond[0][2]:.2f})" in flat
    assert f"(0.27 % of {values} is {0.0027 * values:.1f})" in flat
    # the goal, in two runs of the same commit with bitwise the same numbers
    again = load("full_scan_67c51b6_run2.json")
    again_wall = load("full_scan_67c51b6_run2_wall.json")
    assert again_wall["scan"] == "docs/scan_compare/full_scan_67c51b6_run2.json"
    keys = ("D", "D_se", "E", "E_se", "E_x", "E_x_se", "events")
    assert all(p[k] == q[k] for p, q in zip(final["points"], again["points"], strict=True)
               for k in keys)  # fmt: skip
    assert max(wall["wall_s"], again_wall["wall_s"]) <= 600
    assert (f"The 10-minute goal is reached, by a few seconds: the scan took {wall['wall_s']:.0f} "
            f"s, and {again_wall['wall_s']:.0f} s ({again['cpu_s']:.0f} s of CPU time) in a second "
            "run of the same commit") in flat  # fmt: skip
    spread = abs(scans["0e2c1d6"][1]["wall_s"] - before_wall["wall_s"])
    assert spread > 600 - wall["wall_s"]  # "a few seconds is also how much ... varies"


def test_the_continuous_billiard_run_on_the_ensembles_event_path():
    """docs/benchmarks.md on 8ec5687: the event loop from shared starts, the two bench runs
    against 23fe8e0 and the flat-flight timing beside them, every number from the committed
    files."""
    text, flat, _ = benchmarks_page()
    folder = ROOT / "docs" / "bench"

    def load(name: str) -> dict:
        return json.loads((folder / name).read_text())

    loop = load("billiard_runs_23fe8e0_8ec5687.json")
    assert loop["trees"] == ["23fe8e0", "8ec5687"] and loop["rounds"] == 5
    assert load_benchmark("billiard_runs").table(loop) in text
    ratios = [row["ratio_to_first"][1] for row in loop["results"]]
    assert min(ratios) > 1.0 and f"The loop gains {min(ratios):.3f}-{max(ratios):.3f}." in flat
    at85 = next(row for row in loop["results"] if row["f"] == 85.2)
    speed85 = at85["median_events_per_cpu_s"][1]
    assert speed85 < 8e6 and f"it makes {speed85:.3g} events per CPU-second: still short" in flat
    same = [row["f"] for row in loop["results"] if row["bitwise_as_first"][1]]
    assert same == [58.0] and "in the same state in both trees only at 58 Hz" in flat
    spread = max(max(r) / min(r) for row in loop["results"] for r in row["events_per_cpu_s"])
    assert f"(at most {100 * (spread - 1):.1f} % between rounds of one tree)" in flat
    bench = load("bench_trees_23fe8e0_8ec5687.json")
    run1 = load("bench_trees_23fe8e0_8ec5687_run1.json")
    trees = load_benchmark("bench_trees")
    for target in ("flat", "billiard"):
        assert trees.doc_table(bench, target) in text
    one, cont, ens = bench["billiard"]
    # "the two runs disagree far beyond the spread of the loop's rounds"
    assert abs(run1["billiard"][1]["ratio"] - cont["ratio"]) > 3 * (spread - 1)
    assert f"The continuous run** ({cont['ratio']:.3f})" in flat
    assert f"2 repeats) gave {run1['billiard'][1]['ratio']:.3f}" in flat and run1["repeats"] == 2
    assert f"One billiard flight** ({one['ratio']:.3f})" in flat
    assert f"the one-flight row moved by {one['ratio']:.3f} above on other flights alone" in flat
    from bbdyn.scenes import b2_billiard

    assert f"at every {b2_billiard.STATE_STRIDE}th event from there (`STATE_STRIDE`)" in flat
    assert f"The ensemble** ({ens['ratio']:.3f})" in flat
    r3, r1 = ([row["ratio"] for row in b["flat"]] for b in (bench, run1))
    assert (f"The flat rows** ({min(r3):.3f}-{max(r3):.3f} here, "
            f"{min(r1):.3f}-{max(r1):.3f} in the first run)") in flat  # fmt: skip
    timing = load("flat_flights_23fe8e0_8ec5687.json")
    a, b = timing["results"]
    assert timing["trees"] == ["23fe8e0", "8ec5687"] and b["bitwise_as_first"]
    assert (f"gives {b['ratio_to_first']:.3f} per flight ({a['median_ns_per_flight']:.1f} and "
            f"{b['median_ns_per_flight']:.1f} ns") in flat  # fmt: skip
    earlier = load("flat_flights_e7de300.json")["results"][0]
    assert earlier["median_ns_per_flight"] < a["median_ns_per_flight"]  # "slower in this hour"
    assert f"took {earlier['median_ns_per_flight']:.1f} ns in the previous section's run" in flat
    flat_speed, cont_speed = bench["flat"][0]["8ec5687"]["speed"], cont["8ec5687"]["speed"]
    assert flat_speed < 1e7 and cont_speed < 8e6
    assert (f"out of reach: {flat_speed:.3g} impacts/s against 1e7 for the flat ball, and "
            f"{cont_speed:.3g} collisions/s against 8e6") in flat  # fmt: skip


def test_the_taylor_finish_one_step_sooner():
    """docs/benchmarks.md on 3683268, 96ff475 and e2a9cae: the flat flight, the ensemble kernel,
    the billiard's event loop and the bench runs against 4b5c1c6, both full scans of the same
    hour, the scan against S3_full and the Lyapunov exponents, every number from the committed
    files."""
    from bbdyn.scenes.b2_scan_cost import measured_speedup_table, measured_table

    m = load_benchmark("scan_compare")
    text, flat, load = benchmarks_page()

    # 32ab3f6 (drive_tail returns from each branch) computes bitwise what e2a9cae does
    for name in ("flat_flights", "billiard_runs"):
        check = bench_file(f"{name}_e2a9cae_32ab3f6.json")
        assert check["trees"] == ["e2a9cae", "32ab3f6"]
        flags = [r["bitwise_as_first"] for r in check["results"]]
        assert all(f if isinstance(f, bool) else all(f) for f in flags)
    # the second scan, at 8524432: 3 points differ from e2a9cae's, within noise, and its time
    second, second_w = load("full_scan_8524432.json"), load("full_scan_8524432_wall.json")
    first, first_w = load("full_scan_e2a9cae.json"), load("full_scan_e2a9cae_wall.json")
    assert second_w["scan"] == "docs/scan_compare/full_scan_8524432.json"
    pairs = list(zip(second["points"], first["points"], strict=True))
    moved = [p["f"] for p, q in pairs if any(p[k] != q[k] for k in ("D", "E", "E_x", "events"))]
    worst = max(abs(p[k] - q[k]) / math.hypot(p[k + "_se"], q[k + "_se"])
                for p, q in pairs for k in ("D", "E", "E_x") if p[k] != q[k])  # fmt: skip
    assert moved == [63.2, 63.6, 71.2] and worst < 0.5
    assert (f"differs from it at {len(moved)} of {len(pairs)} points (63.2, 63.6 and 71.2 Hz), by "
            f"at most {worst:.2f} combined standard errors") in flat  # fmt: skip
    assert (
        f"That run took {second_w['wall_s']:.0f} s wall and {second['cpu_s']:.0f} s of CPU "
        f"time, against {first_w['wall_s']:.0f} s and {first['cpu_s']:.0f} s for e2a9cae"
    ) in flat
    # the flat flight in a compiled loop
    timing = bench_file("flat_flights_4b5c1c6_e2a9cae.json")
    assert timing["trees"] == ["4b5c1c6", "e2a9cae"] and timing["rounds"] == 5
    assert load_benchmark("flat_flights").table(timing) in text
    a, b = timing["results"]
    per_s = 1e9 / b["median_ns_per_flight"]
    assert b["evals_per_flight"] < a["evals_per_flight"] and not b["bitwise_as_first"]
    assert (f"A flight takes {b['median_ns_per_flight']:.1f} ns instead of "
            f"{a['median_ns_per_flight']:.1f} ns ({b['ratio_to_first']:.3f}), with "
            f"{b['evals_per_flight']:.3f} gap evaluations instead of {a['evals_per_flight']:.3f}: "
            f"{per_s:.3g} flights per CPU-second in this compiled loop") in flat  # fmt: skip
    # the ensemble kernel: unchanged below 71 Hz, gains above
    kernel = load("kernel_buffers_4b5c1c6_e2a9cae.json")
    assert kernel["trees"] == ["4b5c1c6", "e2a9cae"]
    assert load_benchmark("kernel_buffers").doc_table(kernel) in text
    low = [r["ratio"] for r in kernel["results"] if r["f"] <= 70.2]
    high = [r["ratio"] for r in kernel["results"] if r["f"] >= 75]
    assert max(abs(r - 1) for r in low) < 0.03 and min(high) > 1.05
    assert (f"the kernel is unchanged ({min(low):.2f}-{max(low):.2f}); at 75-90 Hz it gains "
            f"{min(high):.2f}-{max(high):.2f}") in flat  # fmt: skip
    # the billiard's event loop from shared starts
    loop = bench_file("billiard_runs_4b5c1c6_e2a9cae.json")
    assert loop["trees"] == ["4b5c1c6", "e2a9cae"] and loop["rounds"] == 5
    assert load_benchmark("billiard_runs").table(loop) in text
    rows = {r["f"]: r for r in loop["results"]}
    up = [rows[f]["ratio_to_first"][1] for f in (70.0, 85.2, 90.0)]
    assert [f for f, r in rows.items() if r["bitwise_as_first"][1]] == [58.0]
    spread = max(max(r) / min(r) for row in loop["results"] for r in row["events_per_cpu_s"])
    at85 = rows[85.2]["median_events_per_cpu_s"]
    assert (f"The loop gains {min(up):.3f}-{max(up):.3f} at 70-90 Hz and "
            f"{rows[58.0]['ratio_to_first'][1]:.3f} at 58 Hz, where both trees make bitwise the "
            f"same events (rounds of one tree differ by at most {100 * (spread - 1):.1f} %). At "
            f"85.2 Hz it makes {at85[1]:.3g} events per CPU-second from this start"
            ) in flat  # fmt: skip
    # bbdyn bench before and after
    bench = bench_file("bench_trees_4b5c1c6_e2a9cae.json")
    trees = load_benchmark("bench_trees")
    for target in ("flat", "billiard"):
        assert trees.doc_table(bench, target) in text
    default, cont_f = bench["flat"][:2]
    loose = next(r for r in bench["flat"] if r["setting"] == "step_rel=0.0001")
    assert all(loose["4b5c1c6"][k] == loose["e2a9cae"][k]
               for k in ("max_time_error_s", "max_velocity_error"))  # fmt: skip
    assert (f"The default row gains only {default['ratio']:.3f} here, against "
            f"{1 / b['ratio_to_first']:.3f} per flight in the compiled loop above. The row is the "
            f"median of {bench['repeats']} timed calls") in flat  # fmt: skip
    assert f"has the same errors in both trees, reads {loose['ratio']:.3f}" in flat
    assert f"The continuous run gains {cont_f['ratio']:.3f}." in flat
    d0, d1 = default["4b5c1c6"], default["e2a9cae"]
    one, cont, ens = bench["billiard"]
    o0, o1 = one["4b5c1c6"], one["e2a9cae"]
    assert (
        f"largest time error is {d1['max_time_error_s']:.1e} s (before: "
        f"{d0['max_time_error_s']:.1e} s) and its largest velocity error "
        f"{d1['max_velocity_error']:.1e} mm/s (before: {d0['max_velocity_error']:.1e})"
    ) in flat
    assert o0["max_time_error_s"] == o1["max_time_error_s"]
    assert (
        f"The billiard's are {o1['max_time_error_s']:.0e} s (unchanged) and "
        f"{o1['max_velocity_error']:.1e} mm/s (before: {o0['max_velocity_error']:.1e})"
    ) in flat
    assert max(d1["max_time_error_s"], o1["max_time_error_s"]) < 1e-12
    assert (f"One flight gains {one['ratio']:.3f}, the continuous run {cont['ratio']:.3f}, the "
            f"ensemble on 2 threads {ens['ratio']:.3f}") in flat  # fmt: skip
    # both full scans of the same hour
    scans = timed_scans(load, ("e2a9cae", "4b5c1c6"), flat)
    (new, new_w), (base, base_w) = scans["e2a9cae"], scans["4b5c1c6"]
    old, old_w = load("full_scan_67c51b6.json"), load("full_scan_67c51b6_wall.json")
    keys = ("D", "D_se", "E", "E_se", "E_x", "E_x_se", "events")
    assert all(p[k] == q[k] for p, q in zip(base["points"], old["points"], strict=True)
               for k in keys)  # fmt: skip
    assert (f"which took {old_w['wall_s']:.0f} s and {old['cpu_s']:.0f} s on its day: the same "
            f"work took {base['cpu_s'] / old['cpu_s']:.2f} times the CPU time") in flat  # fmt: skip
    assert measured_table(new["points"]) in text
    assert measured_speedup_table(base["points"], new["points"]) in text
    assert (f"The scan gains {base['cpu_s'] / new['cpu_s']:.2f} in CPU time and "
            f"{base_w['wall_s'] / new_w['wall_s']:.2f} in wall time") in flat  # fmt: skip
    # against S3_full
    beyond = agreement_with_s3_full(m, "e2a9cae", text)
    assert [(name, x) for name, x, _ in beyond] == [("E", 85.2), ("E_x", 78.2)]
    values = 3 * len(new["points"])
    assert (f"Two points in {values} lie beyond 3 combined standard errors (E at 85.2 Hz, z = "
            f"{beyond[0][2]:.2f}, and E_x at 78.2 Hz, z = {beyond[1][2]:.2f}), about what noise "
            f"gives (0.27 % of {values} is {0.0027 * values:.1f})") in flat  # fmt: skip
    # the Lyapunov exponents before and after, in combined standard errors
    lyap = bench_file("lyapunov_4b5c1c6_e2a9cae.json")
    assert lyap["trees"] == ["4b5c1c6", "e2a9cae"]
    z = {}
    for g in lyap["groups"]:
        p, q = g["4b5c1c6"], g["e2a9cae"]
        scale = math.hypot(p["lam1_per_s_se"], q["lam1_per_s_se"])
        if scale > 0:
            z[g["run"], g["f"], g["group"]] = abs(q["lam1_per_s"] - p["lam1_per_s"]) / scale
    short = max(v for k, v in z.items() if k[0] == "short")
    long = max(v for k, v in z.items() if k[0] == "long")
    assert max(short, long) < 2.0
    assert (f"moves by at most {short:.2f} combined standard errors in the short runs and "
            f"{long:.2f} in the long ones") in flat  # fmt: skip
    lyapunov_md = (ROOT / "docs" / "lyapunov.md").read_text()
    assert "| 85.2 | d | 0: intermittent | 0.95 |" in lyapunov_md  # 19 of 20 particles
    # the targets
    loop85 = rows[85.2]["median_events_per_cpu_s"]
    assert one["e2a9cae"]["speed"] > 8e6 and cont["e2a9cae"]["speed"] > 8e6 > loop85[1]
    assert default["e2a9cae"]["speed"] < 1e7 < per_s
    assert (
        f"one flight {one['e2a9cae']['speed']:.3g} and a continuous run "
        f"{cont['e2a9cae']['speed']:.3g} collisions/s, both above the target of 8e6. The same "
        f"event loop from `billiard_runs.py`'s start makes {loop85[1]:.3g} (4b5c1c6: "
        f"{loop85[0]:.3g}, against {cont['4b5c1c6']['speed']:.3g} in the bench)"
    ) in flat
    assert (f"The flat ball: {default['e2a9cae']['speed']:.3g} impacts/s in `bbdyn bench flat` "
            f"against 1e7, {per_s:.3g} flights per CPU-second in the compiled loop. The full scan "
            f"took {new_w['wall_s']:.0f} s against the 10 minutes, in an hour when the previous "
            f"kernel took {base_w['wall_s']:.0f} s") in flat  # fmt: skip
    assert new_w["wall_s"] < base_w["wall_s"]


def test_sample_times_no_longer_end_the_skips():
    """docs/benchmarks.md on 2dcadef: the scan's points in both trees, both full scans of the
    same hour, how they differ, the scan against S3_full and the targets, every number from
    the committed files."""
    from bbdyn.scenes.b2_scan_cost import (
        agreement_sentence,
        measured_speedup_table,
        measured_table,
    )

    m = load_benchmark("scan_compare")
    text, flat, load = benchmarks_page()
    # the scan's points at n = 100, interleaved
    points = load("scan_points_38a14d2_2dcadef.json")
    assert points["trees"] == ["38a14d2", "2dcadef"] and points["n"] == 100
    assert load_benchmark("scan_points").table(points) in text
    bands = {row["band"]: row["ratio"] for row in points["bands"]}
    assert (f"The chattering-and-sticking bands gain most: {bands['53.2-57.4']:.2f} at "
            f"53.2-57.4 Hz and {bands['57.6-65']:.2f} at 57.6-65 Hz") in flat  # fmt: skip
    assert f"the bands are unchanged ({bands['65.2-80']:.2f}, {bands['80.2-95']:.2f})" in flat
    cpu = {f: [rows[j]["cpu_s"] for rows in points["points"]]
           for j, f in enumerate(p["f"] for p in points["points"][0])}  # fmt: skip
    gain = {f: a / b for f, (a, b) in cpu.items()}
    assert sorted(gain, key=gain.get)[-2:] == [79.0, 70.2]
    assert (f"single points {gain[70.2]:.2f} (70.2 Hz), {gain[79.0]:.2f} (79 Hz) and "
            f"{gain[63.0]:.2f} (63 Hz)") in flat  # fmt: skip
    assert f"At 70.2 Hz a point cost {gain[70.2]:.1f} times what it costs now" in flat
    # both full scans of the same hour; the old one is bitwise the scan at 8524432
    scans = timed_scans(load, ("2dcadef", "38a14d2"), flat)
    (new, new_w), (base, base_w) = scans["2dcadef"], scans["38a14d2"]
    before = load("full_scan_8524432.json")
    keys = ("D", "D_se", "E", "E_se", "E_x", "E_x_se", "events")
    assert all(p[k] == q[k] for p, q in zip(base["points"], before["points"], strict=True)
               for k in keys)  # fmt: skip
    assert f"(which took {load('full_scan_8524432_wall.json')['wall_s']:.0f} s in its hour)" in flat
    assert measured_table(new["points"]) in text
    assert measured_speedup_table(base["points"], new["points"]) in text
    assert (f"The scan gains {base['cpu_s'] / new['cpu_s']:.2f} in CPU time and "
            f"{base_w['wall_s'] / new_w['wall_s']:.2f} in wall time") in flat  # fmt: skip
    old_pts = {p["f"]: p for p in base["points"]}
    new_pts = {p["f"]: p for p in new["points"]}
    first = [f"{new_pts[f]['cpu_s']:.2f} s" for f in (49.8, 50.0)]
    first += [f"{old_pts[f]['cpu_s']:.2f} s" for f in (49.8, 50.0)]
    assert "({} and {} against {} and {})".format(*first) in flat
    assert (f"({old_pts[52.6]['cpu_s']:.2f} s to {new_pts[52.6]['cpu_s']:.2f} s at 52.6 Hz)"
            in flat)  # fmt: skip
    # how the two scans differ
    pairs = list(zip(base["points"], new["points"], strict=True))
    assert all(p["events"] == q["events"] for p, q in pairs)
    sentence = agreement_sentence(base["points"], new["points"])
    same = int(sentence.split(" of ")[0])
    assert f"{same} of {len(pairs)} points have the same D, E and E_x" in flat
    for key, bound in (("E", 1e-12), ("E_x", 2e-12)):
        rel = max(abs(p[key] - q[key]) / abs(p[key]) for p, q in pairs if p[key] != q[key])
        assert rel <= 1.5 * bound
    assert "E and E_x move by at most 1e-12 and 2e-12 of their values" in flat
    moved = [(p, q) for p, q in pairs if p["D"] != q["D"]]
    size = [max(abs(p["D"]), abs(q["D"])) for p, q in moved]
    large = [abs(p["D"] - q["D"]) / s for (p, q), s in zip(moved, size, strict=True) if s > 1e-3]
    middle = [(abs(p["D"] - q["D"]) / max(p["D_se"], q["D_se"]), s)
              for (p, q), s in zip(moved, size, strict=True) if D_ZERO < s <= 1e-3]  # fmt: skip
    tiny = [(p, q) for (p, q), s in zip(moved, size, strict=True) if s <= D_ZERO]
    assert (f"D moves by at most {max(large):.0e} of its value at the {len(large)} points where "
            f"it exceeds 1e-3 mm^2/s, and by at most {max(z for z, _ in middle):.1e} of its "
            f"standard error at the {len(middle)} points where it lies between {D_ZERO:.0e} and "
            f"{max(s for _, s in middle):.1e} mm^2/s") in flat  # fmt: skip
    tiny_f = [p["f"] for p, _ in tiny]
    assert tiny_f == [54.6, 55.0, 55.4, 56.0, 57.0]
    top = max(max(abs(p["D"]), abs(q["D"])) for p, q in tiny)
    noise = max(abs(p["D"] - q["D"]) / max(p["D_se"], q["D_se"]) for p, q in tiny)
    assert all(p["trapped"] == 0 and p["stuck_fraction"] < 1 for p, _ in tiny)
    assert (f"At {len(tiny)} points (54.6, 55, 55.4, 56 and 57 Hz) D is below {top:.1e} mm^2/s on "
            f"both sides") in flat  # fmt: skip
    assert f"moves by up to {noise:.1f} of its standard error" in flat
    # against S3_full
    beyond = agreement_with_s3_full(m, "2dcadef", text)
    assert [(name, x) for name, x, _ in beyond] == [("E", 85.2), ("E_x", 78.2)]
    assert (f"(E at 85.2 Hz, z = {beyond[0][2]:.2f}, and E_x at 78.2 Hz, z = "
            f"{beyond[1][2]:.2f})") in flat  # fmt: skip
    s3 = m.load_old(ROOT / "docs" / "figures" / "S3_full.npz")
    z_old = m.z_scores(s3, m.load_new(ROOT / "docs" / "scan_compare" / "full_scan_38a14d2.json"))
    z_new = m.z_scores(s3, m.load_new(ROOT / "docs" / "scan_compare" / "full_scan_2dcadef.json"))
    change = np.abs(z_new["D"]["z"] - z_old["D"]["z"])
    worst = [float(z_new["f"][i]) for i in np.argsort(-change)[:2]]
    assert worst == [57.0, 54.6]
    at = [int(np.argmin(np.abs(z_new["f"] - x))) for x in worst]
    zn, zo = z_new["D"]["z"], z_old["D"]["z"]
    assert (f"{zn[at[0]]:.2f} and {zn[at[1]]:.2f} against {zo[at[0]]:.2f} and {zo[at[1]]:.2f} "
            "at 38a14d2") in flat  # fmt: skip
    # the targets
    assert new_w["wall_s"] < 600 < base_w["wall_s"] + 60
    bench = bench_file("bench_trees_4b5c1c6_e2a9cae.json")
    one, cont = bench["billiard"][:2]
    default = bench["flat"][0]
    speeds = [row["e2a9cae"]["speed"] for row in (one, cont, default)]
    assert (
        "one flight {:.3g} and a continuous run {:.3g} billiard collisions/s, above the "
        "target of 8e6; the flat ball {:.3g} impacts/s, below 1e7".format(*speeds)
    ) in flat
    assert (f"The full scan took {new_w['wall_s']:.0f} s wall on the 2 cores, within the 10 "
            f"minutes (38a14d2 took {base_w['wall_s']:.0f} s in the same hour") in flat  # fmt: skip


def test_issue_12_from_start_to_end():
    """docs/benchmarks.md, 'Issue 12 from start to end': bbdyn bench at db5ef1b and e56e7ce in
    one run, the targets, the machine's hour, the cost model before and after, the full scan of
    that hour and the flat variants tried, every number from the committed files."""
    from bbdyn.scenes.b2_scan_cost import band_sums, predicted_vs_measured_table

    text, flat, load = benchmarks_page()

    # bbdyn bench before and after
    bench = bench_file("bench_trees_db5ef1b_e56e7ce.json")
    assert bench["trees"] == ["db5ef1b", "e56e7ce"] and not bench["quick"]
    assert bench["repeats"] == 3 and "--repeats 3" in flat
    trees = load_benchmark("bench_trees")
    for target in ("flat", "billiard"):
        assert trees.doc_table(bench, target) in text
    default, cont_f = bench["flat"][:2]
    one, cont, ens = bench["billiard"]
    ratios = [row["ratio"] for row in (default, cont_f, one, cont, ens)]
    assert ("The flat ball's one flight gains {:.3f} and its continuous run {:.3f}; the "
            "billiard's one flight {:.3f}, its continuous run {:.3f} and the ensemble on 2 "
            "threads {:.3f}".format(*ratios)) in flat  # fmt: skip
    errors = [row[tree]["max_time_error_s"] for row in (default, one)
              for tree in ("db5ef1b", "e56e7ce")]  # fmt: skip
    assert max(errors) < 1e-12
    dt_flat, dt_billiard = (row["e56e7ce"]["max_time_error_s"] for row in (default, one))
    assert (f"largest time error is {dt_flat:.1e} s for the flat ball and {dt_billiard:.0e} s "
            "for the billiard") in flat  # fmt: skip
    # the targets, stated as met or missed by the numbers
    speeds = [row["e56e7ce"]["speed"] for row in (default, one, cont)]
    targets = (1e7, 8e6, 8e6)
    assert speeds[0] < targets[0] and speeds[1] >= targets[1] and speeds[2] < targets[2]
    assert (f"the flat ball, one flight: {speeds[0]:.3g} impacts/s against 1e7, **missed** "
            f"({speeds[0] / targets[0]:.3f} of it)") in flat  # fmt: skip
    assert f"the billiard, one flight: {speeds[1]:.3g} collisions/s against 8e6, met" in flat
    other_hour = bench_file("bench_trees_4b5c1c6_e2a9cae.json")["billiard"][1]["e2a9cae"]["speed"]
    assert (f"the billiard, continuous run: {speeds[2]:.3g} collisions/s against 8e6, **missed "
            f"in this hour** ({speeds[2] / targets[2]:.3f} of it; {other_hour:.3g} at "
            "e2a9cae") in flat  # fmt: skip
    # the hour: the same flights, bitwise, then and now
    now = bench_file("flat_flights_e2a9cae_e56e7ce.json")
    assert now["trees"] == ["e2a9cae", "e56e7ce"] and now["rounds"] == 5
    assert all(r["bitwise_as_first"] for r in now["results"])
    assert load_benchmark("flat_flights").table(now) in text
    then = bench_file("flat_flights_4b5c1c6_e2a9cae.json")["results"][1]
    assert then["tree"] == "e2a9cae"
    ns_now, ns_then = now["results"][0]["median_ns_per_flight"], then["median_ns_per_flight"]
    assert (f"e2a9cae's flight took {ns_now:.2f} ns in this hour against {ns_then:.2f} ns in its "
            f"own (`docs/bench/flat_flights_4b5c1c6_e2a9cae.json`): the same code ran "
            f"{ns_now / ns_then:.3f} times slower") in flat  # fmt: skip
    loop = bench_file("billiard_runs_e2a9cae_e56e7ce.json")
    assert loop["trees"] == ["e2a9cae", "e56e7ce"] and loop["rounds"] == 5
    assert all(all(r["bitwise_as_first"]) for r in loop["results"])
    assert load_benchmark("billiard_runs").table(loop) in text
    at85 = {r["f"]: r for r in loop["results"]}[85.2]["median_events_per_cpu_s"][0]
    old = bench_file("billiard_runs_4b5c1c6_e2a9cae.json")
    at85_then = {r["f"]: r for r in old["results"]}[85.2]["median_events_per_cpu_s"][1]
    assert (f"e2a9cae's loop made {at85:.3g} events per CPU-second in this hour against "
            f"{at85_then:.3g} in its own") in flat  # fmt: skip
    # the cost model before and after, against the scans it predicts
    folder = ROOT / "docs" / "scan_compare"
    cost = [bench_file(f"scan_cost_{c}.json")["meta"] for c in ("db5ef1b", "e56e7ce")]
    assert [m["provenance"]["commit"][:7] for m in cost] == ["db5ef1b", "e56e7ce"]
    assert cost[0]["provenance"]["dirty_files"] == [" M bbdyn/scenes/b2_scan_cost.py"]
    assert not cost[1]["provenance"]["dirty"]
    pred = [m["rows"] for m in cost]
    meas = [json.loads((folder / f"full_scan_{c}.json").read_text())["points"]
            for c in ("db5ef1b", "e56e7ce")]  # fmt: skip
    assert predicted_vs_measured_table(pred, meas, ["db5ef1b", "e56e7ce"]) in text
    sums = [band_sums(points) for points in meas]
    for rows, s in zip(pred, sums, strict=True):
        assert all(abs(r["predicted_cpu_s"] - x) <= r["error_cpu_s"]
                   for r, x in zip(rows, s, strict=True))  # fmt: skip
    p_ratio = [a["predicted_cpu_s"] / b["predicted_cpu_s"] for a, b in zip(*pred, strict=True)]
    m_ratio = [a / b for a, b in zip(*sums, strict=True)]
    assert (f"The model predicts a speed-up of {p_ratio[-1]:.2f} for the whole scan "
            f"({min(p_ratio[:-1]):.2f}-{max(p_ratio[:-1]):.2f} per band); the scans measured "
            f"{m_ratio[-1]:.2f} ({min(m_ratio[:-1]):.2f}-{max(m_ratio[:-1]):.2f})"
            ) in flat  # fmt: skip
    # the full scan of this hour: bitwise 2dcadef's numbers
    scan, wall = load("full_scan_e56e7ce.json"), load("full_scan_e56e7ce_wall.json")
    base, base_w = load("full_scan_2dcadef.json"), load("full_scan_2dcadef_wall.json")
    keys = ("D", "D_se", "E", "E_se", "E_x", "E_x_se", "events")
    assert all(p[k] == q[k] for p, q in zip(scan["points"], base["points"], strict=True)
               for k in keys)  # fmt: skip
    assert wall["scan"] == "docs/scan_compare/full_scan_e56e7ce.json"
    beyond = agreement_with_s3_full(load_benchmark("scan_compare"), "2dcadef", text)
    assert len(beyond) == 2 and all(name != "D" for name, _, _ in beyond)
    values = 3 * len(scan["points"])
    assert f"no D beyond 3 combined standard errors, 2 of the {values} values in all" in flat
    assert (f"{wall['wall_s']:.0f} s wall and {scan['cpu_s']:.0f} s of CPU time. Its D, E, E_x"
            in flat)  # fmt: skip
    assert (f"the scan at 2dcadef ({base_w['wall_s']:.0f} s and {base['cpu_s']:.0f} s of CPU "
            f"time in its hour)") in flat  # fmt: skip
    assert wall["wall_s"] <= 600 and base_w["wall_s"] <= 600
    assert (f"The 10-minute goal is met, by {600 - wall['wall_s']:.1f} s in this hour and by "
            f"{600 - base_w['wall_s']:.0f} s in 2dcadef's") in flat  # fmt: skip
    diffusion = " ".join((ROOT / "docs" / "diffusion.md").read_text().split())
    times = (base_w["wall_s"], wall["wall_s"], base["cpu_s"], scan["cpu_s"])
    assert ("{:.0f} s and {:.0f} s wall on the 2 cores, {:.0f} s and {:.0f} s of CPU "
            "time".format(*times)) in diffusion  # fmt: skip
    start = load("full_scan_db5ef1b.json")["cpu_s"]
    assert (f"At db5ef1b the same scan took {start:.0f} s of CPU time, "
            f"{start / scan['cpu_s']:.2f} times as much") in flat  # fmt: skip
    # the flat variants tried
    variants = bench_file("flat_flights_e56e7ce_variants.json")
    assert variants["trees"][0] == "e56e7ce" and variants["rounds"] == 5
    assert load_benchmark("flat_flights").table(variants) in text
    ratio = {r["tree"].split("+")[-1]: r["ratio_to_first"] for r in variants["results"]}
    assert ratio["estrin_both"] < ratio["estrin_sincos"] < 1 < ratio["sincos_select"]
    assert f"together they take {ratio['estrin_both']:.3f} of the time on this loop" in flat
    assert f"for {100 * (1 - ratio['estrin_both']):.1f} % of one flight" in flat
    assert f"(`sincos_select`) are slower ({ratio['sincos_select']:.3f})" in flat
