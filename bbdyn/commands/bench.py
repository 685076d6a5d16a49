"""`bbdyn bench TARGET [--quick] [--json] [--out PNG]`: work-precision benchmarks (B2).

A target is a module registered in ``TARGETS`` that provides ``QUICK`` and
``FULL`` (settings dicts), ``compute(settings, log=...) -> Result`` whose
``meta["rows"]`` is a list of dicts (at least ``method``, ``setting``,
``impacts_per_s``, ``max_time_error_s``, ``max_velocity_error``), ``table(result)
-> str`` and ``draw(result) -> Figure``.  Add the billiard benchmark by adding
its module here.
"""

import json

HELP = "work-precision benchmark (SCENES.md B2): speed and error against an mpmath reference"

#: target name -> module providing QUICK, FULL, compute, table, draw
TARGETS = {"flat": "bbdyn.benchmarking.flat", "billiard": "bbdyn.benchmarking.billiard"}


def add_arguments(parser) -> None:
    parser.add_argument("target", choices=sorted(TARGETS), help="what to benchmark")
    parser.add_argument("--quick", action="store_true", help="quick setting (< 60 s)")
    parser.add_argument("--json", action="store_true", help="print one JSON object per row")
    parser.add_argument(
        "--out", default=None, help="figure path (default out/bench_TARGET.png); numbers beside it"
    )
    parser.add_argument(
        "--impacts", type=int, default=None, help="override the number of compared impacts"
    )
    parser.add_argument(
        "--long-run", type=int, default=None, help="override the impacts of the long-run statistics"
    )


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
            if value < 1:
                raise ValueError(f"--{key.replace('_', '-')} must be >= 1, got {value}")
            settings[key] = value
    result = module.compute(settings)
    result.meta["setting"] = "quick" if args.quick else "full"
    png = Path(args.out) if args.out else Path("out") / f"bench_{args.target}.png"
    result.save(png.with_suffix(""))
    fig = module.draw(result)
    fig.savefig(png, dpi=150, bbox_inches="tight")
    plt.close(fig)
    if args.json:
        print(json.dumps(result.meta["rows"], indent=1))
    else:
        print(module.table(result))
        print(f"\nfigure: {png}; numbers: {png.with_suffix('.json')}")
    return 0
