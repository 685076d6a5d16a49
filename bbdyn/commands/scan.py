"""`bbdyn scan --f-start 49.8 --f-stop 95 --f-step 0.2 --n 1000 --t 200 --out DIR`: D(f) and E(f).

``--device cuda`` runs every frequency together on this machine's GPU (docs/gpu.md).

Runs ``bbdyn.scans.frequency.diffusion_point`` at every frequency of the grid with
``bbdyn.scans.runner.run_scan``: each finished frequency is stored at once in ``DIR``;
``--resume`` finishes an interrupted scan.  When the scan is complete the whole scan is
also written as one netCDF file, ``DIR/scan.nc`` (``ScanResult.to_netcdf``; needs the io
extra, else a note says so).  Prints one line per frequency (D with
its standard error, E, E_x, flags) or, with ``--json``, one JSON object.  The model
parameters other than f are options as in every command (``--A --alpha --beta --R --d``).

JSON keys (docs/schema.md): ``version``, ``params`` (A mm, g mm/s^2, alpha, beta, R mm,
d mm; f is scanned), ``seed``, ``out``, ``n``, ``t`` (s), ``points``, ``cpu_s``, ``wall_s``
(s), ``units``.  ``points``: one object per frequency with ``f`` (Hz), ``gamma``, ``D``,
``D_se`` (mm^2/s, the keys of ``bbdyn simulate``), ``D_converged``, ``E``, ``E_se``,
``E_x``, ``E_x_se``, ``E_reference`` (kg mm^2/s^2), ``energy_stationary``,
``stuck_fraction``, ``collision_rate`` (per particle per s), ``trapped``, ``events`` (all
events of the point's run), ``cpu_s`` (CPU time of the worker process that ran the point,
one numba thread) and ``wall_s`` (its wall-clock time; on a GPU, the point's share of its
batch), ``device`` and ``device_name`` (where it ran).  The top-level ``cpu_s`` is the
sum of the points' (the workers did the work), ``wall_s`` the wall-clock time of the
command.
"""

from bbdyn.commands import (
    BILLIARD_OPTIONS,
    PARAM_DEFAULTS,
    Clock,
    add_device_argument,
    add_model_arguments,
    duration,
    finite,
    json_output,
    model_values,
    output_file,
    output_folder,
    particles,
    print_json,
    report_written,
    seed,
)
from bbdyn.commands.cli import Interrupted
from bbdyn.scans.frequency import check_scan_size, frequency_grid, frequency_scan, grid_size
from bbdyn.scans.runner import (
    IO_EXTRA,
    MANIFEST,
    ScanBusyError,
    ScanStorageError,
    SchedulerUnreachableError,
    load_scan,
)

HELP = "scan D(f), E(f), E_x(f) over a frequency grid (resumable, parallel; docs/diffusion.md)"
#: The whole scan as one netCDF file, in the scan folder.
NETCDF = "scan.nc"


def add_arguments(parser) -> None:
    parser.add_argument(
        "--f-start", type=finite, default=49.8, help="first frequency in Hz (default: %(default)s)"
    )
    parser.add_argument(
        "--f-stop", type=finite, default=95.0, help="last frequency in Hz (default: %(default)s)"
    )
    parser.add_argument(
        "--f-step", type=finite, default=0.2, help="frequency step in Hz (default: %(default)s)"
    )
    add_model_arguments(parser, BILLIARD_OPTIONS[1:])  # f is scanned
    parser.add_argument(
        "--n", type=particles, default=1000, help="particles per frequency (default: 1000)"
    )
    parser.add_argument(
        "--t", type=float, default=200.0, help="simulated time in s (default: 200)"
    )
    parser.add_argument(
        "--transient",
        type=finite,
        default=None,
        help="time before energy averages (s; default: t/5)",
    )
    parser.add_argument("--seed", type=seed, default=0, help="scan seed (default: 0)")
    parser.add_argument("--out", type=output_folder, required=True, help="scan folder")
    parser.add_argument("--resume", action="store_true", help="finish the scan already in --out")
    parser.add_argument(
        "--workers", type=int, default=None, help="local processes (default: all cores)"
    )
    parser.add_argument(
        "--scheduler",
        default=None,
        help="dask.distributed scheduler address (default: none, local processes)",
    )
    add_device_argument(parser, "the scan (cuda: every frequency together, on this machine)")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument(
        "--progress", type=output_file, default=None,
        help="append progress lines to this file, in an existing folder (default: stderr)",
    )  # fmt: skip


#: The numbers of a scan point in the JSON output (the keys of ``load_scan``, docs/schema.md).
POINT_KEYS = (
    "gamma",
    "D",
    "D_se",
    "D_converged",
    "E",
    "E_se",
    "E_x",
    "E_x_se",
    "E_reference",
    "energy_stationary",
    "stuck_fraction",
    "collision_rate",
    "trapped",
    "events",
)


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """Warnings of the scan (a damaged point computed again) as one line on stderr."""
    import sys

    print(f"bbdyn scan: warning: {message}", file=sys.stderr)


def resume_command(args) -> str:
    """The command line that finishes the scan of ``args`` (``--resume`` once ``--out``
    holds its manifest): the same grid, sizes, seed and model options."""
    import shlex
    from pathlib import Path

    argv = ["bbdyn", "scan", "--f-start", repr(args.f_start), "--f-stop", repr(args.f_stop),
            "--f-step", repr(args.f_step)]  # fmt: skip
    argv += [f"--{k}={v!r}" for k, v in model_values(args).items() if v != PARAM_DEFAULTS[k]]
    argv += ["--n", str(args.n), "--t", repr(args.t), "--seed", str(args.seed)]
    if args.transient is not None:
        argv += ["--transient", repr(args.transient)]
    for option in ("workers", "scheduler", "progress"):
        if getattr(args, option) is not None:
            argv += [f"--{option}", str(getattr(args, option))]
    argv += ["--device", args.device] * (args.device != "cpu")
    argv += ["--out", args.out] + ["--json"] * args.json
    return shlex.join(argv + ["--resume"] * (Path(args.out) / MANIFEST).exists())


def saved_points(out: str) -> str:
    """How many points of the scan in ``out`` are saved, e.g. ``3 of 10 points are saved``."""
    import warnings

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # a damaged point is simply not counted
            scan = load_scan(out, partial=True)
    except (OSError, ValueError):  # no manifest yet, or a damaged one
        return "no point is saved"
    total = len(scan.meta["values"])
    return f"{total - scan.meta['n_missing']} of {total} points are saved"


def run(args) -> int:
    import sys
    import warnings
    from pathlib import Path

    if args.resume and not (Path(args.out) / MANIFEST).is_file():
        raise ValueError(
            f"--resume: {args.out} holds no scan to finish (no {MANIFEST}); check --out, "
            "or leave out --resume to begin a new scan there"
        )

    # size and arguments first: a refused scan allocates and writes nothing
    count = grid_size(args.f_start, args.f_stop, args.f_step)
    f_last = args.f_start + (count - 1) * args.f_step
    cost = check_scan_size(args.f_start, f_last, count, n=args.n, t=args.t,
                           transient=args.transient)  # fmt: skip
    # a bound for refusing oversized scans, not a forecast: the progress line measures the time
    print(f"bbdyn scan: {count} frequencies; the kernels take at most {duration(cost['cpu_s'])} "
          "of CPU time by the conservative event model, plus their compilation on first use (a "
          "bound, not a forecast: real runs make fewer, cheaper events; the progress line gives "
          "the time left once points finish)", file=sys.stderr)  # fmt: skip
    clock = Clock()
    grid = frequency_grid(args.f_start, args.f_stop, args.f_step)
    log = open(args.progress, "a", buffering=1) if args.progress else None  # noqa: SIM115
    try:
        with warnings.catch_warnings():
            warnings.showwarning = _show_warning
            scan = frequency_scan(
                grid,
                out_dir=args.out,
                seed=args.seed,
                n=args.n,
                t=args.t,
                transient=args.transient,
                resume=args.resume,
                workers=args.workers,
                scheduler=args.scheduler,
                progress=log if log else True,
                model=model_values(args),
                device=args.device,
            )
    except KeyboardInterrupt:
        raise Interrupted(
            f"{saved_points(args.out)} in {args.out}; finish the scan with: {resume_command(args)}"
        ) from None
    except FileExistsError:
        raise ValueError(
            f"{args.out} already holds a scan: add --resume to finish it, or choose a new --out"
        ) from None
    except (ScanBusyError, ScanStorageError, SchedulerUnreachableError) as err:
        print(f"bbdyn scan: error: {err}", file=sys.stderr)  # it says what to do
        return 1
    finally:
        if log:
            log.close()
    write_netcdf(scan, args.out, args.json)
    if args.json:
        print_json(scan_output(scan, args, clock))
        return 0
    print(f"{'f (Hz)':>8} {'D (mm^2/s)':>20} {'E':>18} {'E_x':>16} {'A^2w^2/2':>9}  flags")
    for i, f in enumerate(scan.values):
        flags = [name for name, key in (("D-windows", "D_converged"),
                 ("E-drift", "energy_stationary")) if not scan[key][i]]  # fmt: skip
        if scan["trapped"][i]:
            flags.append("trapped")
        print(
            f"{f:8.3f} {scan['D'][i]:11.4g} +- {scan['D_se'][i]:<6.2g}"
            f" {scan['E'][i]:9.5g} +- {scan['E_se'][i]:<5.2g}"
            f" {scan['E_x'][i]:8.4g} +- {scan['E_x_se'][i]:<5.2g} {scan['E_reference'][i]:9.5g}"
            f"  {' '.join(flags)}"
        )
    return 0


def write_netcdf(scan, out: str, json_mode: bool) -> None:
    """Write the finished scan as ``out/scan.nc``; without xarray, a note naming the extra."""
    from pathlib import Path

    path = Path(out) / NETCDF
    try:
        scan.to_netcdf(path)
    except ImportError:
        report_written(f"bbdyn scan: note: {path} not written: {IO_EXTRA}", True)
        return
    report_written(f"netCDF: {path}", json_mode)


def scan_output(scan, args, clock) -> dict:
    """The JSON object of a finished scan: every point with its own CPU and wall time; the
    scan's CPU time is the sum of the points' (the workers' process CPU time)."""
    times = scan.point_times()
    where = [{k: p.get(k) for k in ("device", "device_name")} for p in scan.meta["points"]]
    rows = [
        {"f": float(f), **{k: scan[k][i].item() for k in POINT_KEYS},
         "cpu_s": float(times["cpu_s"][i]), "wall_s": float(times["wall_s"][i]), **where[i]}
        for i, f in enumerate(scan.values)
    ]  # fmt: skip
    params = {**model_values(args), "g": PARAM_DEFAULTS["g"]}  # g is not an option here
    body = {"out": args.out, "n": args.n, "t": args.t, "points": rows}
    out = json_output(body, params=params, clock=clock, seed=args.seed)
    out["cpu_s"] = float(times["cpu_s"].sum())
    return out
