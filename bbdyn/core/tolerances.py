"""Numerical tolerances, derived from machine precision and defined once.

The tests import these too, so an accuracy claim and its check share one number.
"""

import numpy as np

EPS = float(np.finfo(np.float64).eps)  # 2.22e-16

#: The first-contact search stops when the safe step is below this fraction of
#: the flight time: the contact time is then known to a few ulp.
ROOT_STEP_REL = 2.0 * EPS

#: Hard cap on safe steps in one flight.  A transversal contact needs about ten;
#: an exactly tangential (grazing) one converges linearly and may need a few
#: hundred.  Reaching the cap is reported as a status, never ignored.
ROOT_MAX_STEPS = 100_000

#: Chattering is summed in closed form (geometric series of flight times with
#: the local effective gravity) once the estimated error of the accumulation
#: time falls below this fraction of a driving period.
CHATTER_REL_TOL = 64.0 * EPS

#: Most terms of the chattering sum's series in eps = v_t^2 / (g_eff S) (``shrinking_series``
#: in ``billiard.py``); 512 terms reach rounding for eps up to about 0.9 (at alpha = 0.5).
#: Beyond that the bound of the series' rest enters the sum's error budget: the sum is
#: then accepted only for a sequence short enough that the rest does not matter.
SERIES_MAX_TERMS = 512

#: Accuracy target for one impact time of the exact flat map (s), issue 2; the
#: search itself stops at ROOT_STEP_REL of the flight, i.e. ~1e-18 s for 10 ms.
IMPACT_TIME_TOL = 1e-14

#: Closed-form time integrals of observables over one flight or stuck interval
#: (Simpson's rule, exact for the quadratics of a parabola; harmonic closed forms
#: for a particle riding the floor) agree with adaptive quadrature to this
#: relative accuracy: a few dozen roundings of the inputs.
OBS_INTEGRAL_REL_TOL = 64.0 * EPS

#: Relative tolerance asked of scipy.integrate.quad when tests check the closed forms
#: (quad accepts nothing below 50 EPS; on these smooth integrands it does far better).
QUAD_REL_TOL = 64.0 * EPS

#: Newton solver for periodic orbits of the exact flat map (bbdyn.flat.tongues): converged
#: when the closing residual, relative to 2 pi k (phase) and to the velocity scale,
#: is below this.  The flight phases are exact to a few ulp (ROOT_STEP_REL), so a
#: few hundred ulp leaves room for the sum over m flights.
ORBIT_NEWTON_TOL = 256.0 * EPS

#: Newton iterations before giving up (quadratic convergence needs fewer than ten
#: from a good guess; the damped start near a fold needs more).
ORBIT_NEWTON_MAX_ITER = 60

#: Relative step of central finite differences (balances truncation h^2 against
#: rounding EPS/h) and the agreement they can show with an analytic derivative.
FD_STEP_REL = EPS ** (1.0 / 3.0)
FD_AGREE_REL = 1.0e3 * EPS ** (2.0 / 3.0)

#: Relative tolerance of the Brent root finders for tongue boundaries (scipy's
#: brentq requires rtol >= 4 EPS).
BOUNDARY_RTOL = 4.0 * EPS

# ---- billiard (bbdyn.core.billiard) -----------------------------------------------

#: A contact within this fraction of d of a wedge is put on the wedge (rounding of
#: the crossing time leaves the contact point a few ulp of d away from it).
WEDGE_TOL = 4.0 * EPS

#: Reflections at one wedge contact before the particle is taken to have collapsed
#: into the wedge; the wedge is so obtuse that one or two are the rule.
WEDGE_MAX_REFLECTIONS = 16

#: Contacts from the Taylor polynomial of the gap (``billiard.tiny_hop``, a chattering hop
#: from its impact; ``taylor.taylor_finish``, the end of a descending flight): tried when
#: the polynomial's span ``w u_max`` (rad; ``u_max`` the first guess or twice it) is below
#: TAYLOR_MAX_SPAN and the drive's remainder after degree TAYLOR_DEGREE in the rate is
#: below eps of it (``taylor.tail_terms`` picks degree 4, 8 or TAYLOR_DEGREE);
#: Newton stops once the error its last step leaves is below TAYLOR_NEWTON_REL of the
#: flight time, after at most TAYLOR_NEWTON_MAX steps.
TAYLOR_MAX_SPAN = 0.5
TAYLOR_DEGREE = 16
TAYLOR_NEWTON_REL = 4.0 * EPS
TAYLOR_NEWTON_MAX = 8

#: Gap of the billiard checked by the tests: never below -GAP_REL_TOL times the
#: scale of the terms of the gap (``|vyrel| tau + g tau^2 + A + h``), a few ulp each.
GAP_REL_TOL = 64.0 * EPS

#: Relative rounding allowance of a gap evaluated from stored events: the gap at
#: a recorded impact is zero to IMPACT_GAP_REL times the sum of the magnitudes
#: of its terms (``|v tau|``, ``g tau^2 / 2``, ``2 A``, ``|G'| / f`` for the phase rounding).
IMPACT_GAP_REL = 64.0 * EPS

# ---- random walk and Green-Kubo (bbdyn.approx) ---------------------------------------

#: The two routes of the truncated Green-Kubo series (jump correlations and
#: symbol-sequence probabilities) are algebraically equal on +-1 jumps and differ
#: by rounding only: a mean over particles of up to 2^10 rounded probabilities per
#: lag.  Tolerance per unit of the scale D_0 (2 n + 1) of the first n terms.
GK_ROUTES_REL = 64.0 * EPS

#: A closed form evaluated by two different float expressions (library code and
#: a lambdified sympy derivation): a handful of roundings in products and sqrt.
CLOSED_FORM_REL = 16.0 * EPS

#: A departure velocity whose normal component is below this fraction of its
#: magnitude is tangent (alpha = 0 makes V.n = 0 exactly; recomputing it from
#: (vx, vyrel) leaves a few ulp of either sign).
DEPARTURE_REL_TOL = 8.0 * EPS

# ---- diffusion estimates (bbdyn.diffusion) -------------------------------------------------

#: A dot product of m terms is exact to m * DOT_ROUND_PER_TERM times the dot product of
#: the absolute values (Higham's gamma_m = m u / (1 - m u) with u = EPS / 2, doubled for
#: the rounding of the weights, taken relative to ``|t| + |tbar|``, the size of the numbers
#: rounded in t - tbar).  Differences of MSD slopes below this are rounding.
DOT_ROUND_PER_TERM = EPS

# ---- fast-forward of periodic cycles (bbdyn.core.fast_forward) ---------------------

#: A running sum of n terms is exact to n * SUM_ROUND_PER_TERM times the sum of the
#: absolute values of the terms (gamma_n with u = EPS / 2, doubled for margin).  The same
#: bound holds for K times the change of a running sum over one cycle (the change carries the
#: roundings of that cycle's additions), so the two ways differ by at most twice this.
SUM_ROUND_PER_TERM = EPS

#: Converged cycles (``converged_cycle``): a cycle whose releases stay within this distance
#: (mm) of each other and whose proven drift ahead, ``|lam| |x_n - x_{n-p}| / (1 - |lam|)``
#: with the release map's multiplier ``lam`` (``release_map``), is below it too is skipped
#: although it never repeats bit for bit.  1e-12 mm is 1e-12 of a tile: no observable
#: resolves it.
FF_DRIFT_TOL = 1e-12

#: ... and whose last two cycles' integrals (E_x, E_y, g y, stuck time) agree to this
#: relative accuracy: the skipped cycles' integrals are the last one's to that accuracy.
FF_ENERGY_REL_TOL = 1e-12

#: ``tangent_departure`` (core/billiard.py) certifies a clear start of a flight that leaves
#: tangentially with the lower bound ``G(tau) >= G''(0) tau^2 / 2 - J tau^3 / 6``, positive
#: for ``J tau < 3 G''(0)``.  It accepts ``J tau < DEPARTURE_MARGIN G''(0)`` (half of that
#: bound, so rounding of J and G'' cannot matter), otherwise retries with
#: ``tau = DEPARTURE_SHRINK G''(0) / J`` (inside the margin) or half of tau, at most
#: ``DEPARTURE_MAX_TRIES`` times (each try halves tau at least: 2^-64 of a period is
#: far below rounding).
DEPARTURE_MARGIN = 1.5
DEPARTURE_SHRINK = 1.4
DEPARTURE_MAX_TRIES = 64

# ---- floating point (every core kernel) ---------------------------------------------

#: LLVM fast-math flags of every core kernel: only "contract", so that ``a * b + c`` may be
#: one fused multiply-add, rounded once instead of twice.  Never less accurate; no
#: reassociation, no assumptions about inf or nan; the same code in every thread.  Every
#: kernel must carry the same flags (tests/test_architecture.py): numba may reuse a helper
#: compiled for one caller in another, so mixed flags would make results depend on the
#: order of compilation.
FMA = {"contract"}

# The kernels an event loop calls once per event without ``inline="always"`` (the event
# search and what it calls: ``flight_search``, ``collide``, ``stick_release``, the flat
# ball's flight, the flight integrals) are compiled with numba's ``forceinline=True``: LLVM
# inlines them into every caller, which saves the call (the floats the caller keeps in
# registers, spilled around it; the result tuple, returned through memory): 1.2-1.4 times the
# events per second of the ensemble kernel (benchmarks/kernel_buffers.py).  Numba's own
# ``inline="always"`` would type the inlined copies again, a minute or more of compilation
# per kernel.  A function compiled as their callee inherits the flag, so they call only
# functions that carry ``inline="always"`` or ``forceinline`` themselves
# (tests/test_architecture.py): otherwise which caller compiled a helper first would
# decide whether it is inlined, and the numbers could depend on the order of compilation.
