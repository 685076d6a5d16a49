"""Reference methods: the yardsticks the exact kernels are measured against (scene B2).

* ``flat_mpmath``: the flat ball's impacts in high precision (mpmath);
* ``billiard_mpmath``: one billiard flight's contact in high precision (mpmath);
* ``flat_ivp``: a general-purpose ODE solver with a terminal event (scipy's ``solve_ivp``);
* ``fixed_step``, ``fixed_step_billiard``: the paper-like event finders (sample the
  flight at a fixed step, then bisect the crossing);
* ``timing``: how the benchmarks time (compile first, repeat, medians, ratios in one run).

Nothing in bbdyn's results depends on these modules; the benchmarks and tests use them.
Importing this package loads neither scipy, mpmath nor matplotlib.
"""
