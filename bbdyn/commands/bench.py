"""`bbdyn bench TARGET [--quick] [--json] [--out PNG]`: work-precision benchmarks (B2).

A target is a module registered in ``TARGETS`` that provides ``QUICK`` and
``FULL`` (settings dicts), ``compute(settings, log=...) -> Result`` whose
``meta["rows"]`` is a list of dicts (at least ``method``, ``setting``,
``impacts_per_s``, ``max_time_error_s``, ``max_velocity_error``), ``table(result)
-> str`` and ``draw(result) -> Figure``.  Add the billiard benchmark by adding
its module here.
"""

import json

from bbdyn.commands import integer_in, jsonable, output_file, report_written

HELP = "work-precision benchmark (B2): speed and error against an mpmath reference"

#: target name -> module providing QUICK, FULL, compute, table, draw
TARGETS = {"flat": "bbdyn.benchmarking.flat", "billiard": "bbdyn.benchmarking.billiard",
           "scan-cost": "bbdyn.benchmarking.scan_cost"}  # fmt: skip

#: Upper bounds of the overrides, 25 and 100 times the largest full settings (400
#: compared impacts, 100000 long-run impacts).
MAX_IMPACTS, MAX_LONG_RUN = 10_000, 10_000_000
IMPACTS_WHY = "each compared impact needs its own high-precision mpmath reference flight"
LONG_RUN_WHY = "the long run integrates every impact with each fixed-step setting"


def add_arguments(parser) -> None:
    parser.add_argument("target", choices=sorted(TARGETS), help="what to benchmark")
    parser.add_argument("--quick", action="store_true", help="quick setting (< 60 s)")
    parser.add_argument("--json", action="store_true", help="print one JSON object per row")
    parser.add_argument(
        "--out", type=output_file, default=None, metavar="PNG",
        help="figure path in an existing folder, numbers beside it (default: out/bench_TARGET.png)",
    )  # fmt: skip
    parser.add_argument(
        "--impacts", type=integer_in("impacts", 1, MAX_IMPACTS, IMPACTS_WHY), default=None,
        help="number of compared impacts (default: that of the quick or full setting)",
    )  # fmt: skip
    parser.add_argument(
        "--long-run", type=integer_in("long-run", 1, MAX_LONG_RUN, LONG_RUN_WHY), default=None,
        help="impacts of the long-run statistics (default: that of the quick or full setting)",
    )  # fmt: skip


def run(args) -> int:
    import importlib
    from pathlib import Path

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    module = importlib.import_module(TARGETS[args.target])
    settings = dict(module.QUICK if args.quick else module.FULL)
    for key, value in (("n_impacts", args.impacts), ("long_run", args.long_run)):
        if value is not None:
            settings[key] = value
    result = module.compute(settings)
    result.meta["setting"] = "quick" if args.quick else "full"
    png = args.out or Path("out") / f"bench_{args.target}.png"
    result.save(png.with_suffix(""))
    fig = module.draw(result)
    fig.savefig(png, dpi=150, bbox_inches="tight")
    plt.close(fig)
    if args.json:
        print(json.dumps(jsonable(result.meta["rows"]), indent=1))
    else:
        print(module.table(result) + "\n")
    report_written(f"figure: {png}; numbers: {png.with_suffix('.json')}", args.json)
    return 0
