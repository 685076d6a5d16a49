"""`bbdyn bench TARGET [--quick] [--json] [--out PNG]`: work-precision benchmarks (B2).

A target is a view of a B2 scene of the scene registry (``bbdyn.scenes.SCENES``):
``bbdyn bench flat`` runs scene ``B2-FLAT`` at its full (or quick) setting, with
``--impacts`` and ``--long-run`` overriding its sizes, and prints the scene's
``table``; the figure and numbers are saved as for any scene (with provenance).  With
``--json`` it prints one JSON object (docs/schema.md): ``version``, ``params``, ``target``,
``setting``, ``rows`` (the benchmark table, one object per method and setting, its columns
described in docs/benchmarks.md), ``cpu_s``, ``wall_s`` and ``units``.
"""

from bbdyn.commands import Clock, integer_in, json_output, output_file, print_json, report_written
from bbdyn.scenes import run_scene, scene_module

HELP = "work-precision benchmark (B2): speed and error against an mpmath reference"

#: target name -> scene id in ``bbdyn.scenes.SCENES``
TARGETS = {"flat": "B2-FLAT", "billiard": "B2-BILLIARD", "scan-cost": "B2-SCAN-COST"}

#: Upper bounds of the overrides, 25 and 100 times the largest full settings (400
#: compared impacts, 100000 long-run impacts).
MAX_IMPACTS, MAX_LONG_RUN = 10_000, 10_000_000
IMPACTS_WHY = "each compared impact needs its own high-precision mpmath reference flight"
LONG_RUN_WHY = "the long run integrates every impact with each fixed-step setting"


def add_arguments(parser) -> None:
    parser.add_argument("target", choices=sorted(TARGETS), help="what to benchmark")
    parser.add_argument("--quick", action="store_true", help="quick setting (< 60 s)")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
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
    from pathlib import Path

    scene_id = TARGETS[args.target]
    overrides = {k: v for k, v in (("n_impacts", args.impacts), ("long_run", args.long_run))
                 if v is not None}  # fmt: skip
    png = args.out or Path("out") / f"bench_{args.target}.png"
    clock = Clock()
    result, png = run_scene(
        scene_id,
        setting="quick" if args.quick else "full",
        out_dir=png.parent,
        name=png.stem,
        overrides=overrides,
    )
    if args.json:
        body = {"target": args.target, "setting": result.meta["setting"]}
        body["rows"] = result.meta["rows"]
        print_json(json_output(body, params=result.meta.get("params", {}), clock=clock))
    else:
        print(scene_module(scene_id).table(result) + "\n")
    report_written(f"figure: {png}; numbers: {png.with_suffix('.json')}", args.json)
    return 0
