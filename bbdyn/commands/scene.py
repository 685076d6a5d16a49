"""`bbdyn scene ID [--quick|--medium|--full] [--out DIR]`: draw one scene, save its numbers."""

from bbdyn.commands import add_device_argument, add_setting_arguments, output_folder, seed
from bbdyn.scenes import SCENES, run_scene, scene_module

HELP = f"compute and draw one scene ({', '.join(SCENES)}), saving its numbers beside the figure"


def add_arguments(parser) -> None:
    parser.add_argument("scene_id", metavar="ID", help="scene id, e.g. S1")
    add_setting_arguments(parser)
    parser.add_argument(
        "--out", type=output_folder, default="out", help="output folder (default: out)"
    )
    parser.add_argument("--seed", type=seed, default=0, help="random seed (default: 0)")
    add_device_argument(parser, "the scans of S3-S5 and B6")


def run(args) -> int:
    result, png = run_scene(
        args.scene_id, setting=args.setting, out_dir=args.out, seed=args.seed, progress=True,
        device=args.device,
    )  # fmt: skip
    table = getattr(scene_module(args.scene_id), "table", None)
    if table is not None:
        print(table(result) + "\n")
    print(f"{args.scene_id.upper()}: {png} ({result.meta['scene_wall_s']:.1f} s)")
    return 0
