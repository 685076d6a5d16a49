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
