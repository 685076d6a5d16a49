"""``python -m bbdyn``: the ``bbdyn`` command line (``bbdyn.commands.cli.main``)."""

import sys

from bbdyn.commands.cli import main

if __name__ == "__main__":
    sys.exit(main())
