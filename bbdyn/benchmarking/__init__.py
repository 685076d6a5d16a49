"""Benchmarks (scene B2, docs/model.md §6): timing helpers, reference methods, work-precision.

``timing`` is generic (compile first, repeat, medians, ratios within one run);
``flat`` is the flat-ball benchmark; ``fixed_step`` the paper-like event finder
it compares against.  Importing this package loads neither scipy nor matplotlib.
"""
