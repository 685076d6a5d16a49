"""Subcommands of the ``bbdyn`` CLI, one module each (see ``bbdyn.cli``)."""
