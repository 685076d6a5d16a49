"""Many runs: resumable scans over a parameter, and what they measure.

* ``runner``: ``run_scan``/``load_scan``, one stored point per value, resumable, local
  processes or a dask cluster, the same numbers either way (seeds from the value);
* ``progress``: the progress line of long runs (stderr, only on a terminal);
* ``frequency``: ``diffusion_point``/``frequency_scan``, D and the energies against f
  (scenes S3-S5, B6);
* ``green_kubo``: random walk and Green-Kubo numbers against f (scenes S9, S10);
* ``statcost``: standard error of D against CPU time (scene B3);
* ``fine_structure``: the structure test of a function measured on nested grids (B6);
* ``cache``: where the scan behind a scene setting is kept, and how a scene gets it.

The scans use the one-run API (``bbdyn.ensemble``, ``bbdyn.diffusion``, ...) and know
nothing of scenes or the command line.
"""
