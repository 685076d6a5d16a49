"""Benchmarks (scene B2, docs/model.md §6): the same as ``bbdyn bench TARGET``.

Usage: ``python benchmarks/run.py flat|billiard [--quick] [--json] [--out PNG]``.
"""

import argparse
import sys

from bbdyn.commands import bench

if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=bench.HELP)
    bench.add_arguments(parser)
    sys.exit(bench.run(parser.parse_args(sys.argv[1:])))
