"""Event kinds, run status codes and fast-forward modes shared by all kernels.

Kernels return these integers; the Python layer turns a failure status into an
exception whose message is ``STATUS_MESSAGES[code]``.
"""

# Event kinds recorded at each event of a trajectory.
IMPACT = 0  #: a collision with the floor
STICK = 1  #: end of chattering, zero relative velocity or a wedge collapse: rides the floor
RELEASE = 2  #: leaves with the floor's velocity at sin(w t) = -1/Gamma (at once inside the window)

EVENT_NAMES = {IMPACT: "impact", STICK: "stick", RELEASE: "release"}

# Run status.
OK = 0  #: ran the requested number of events or up to the requested time
STUCK_FOREVER = 1  #: stuck on the floor with Gamma <= 1: it never leaves (a normal end)
ROOT_NOT_CONVERGED = 2  #: the first-contact search reached ROOT_MAX_STEPS
NON_FINITE = 3  #: a NaN or infinity appeared in the state
BAD_STATE = 4  #: the initial state is not allowed (e.g. below the floor)

STATUS_MESSAGES = {
    OK: "ok",
    STUCK_FOREVER: "stuck on the floor for good: Gamma <= 1, the floor never pulls away",
    ROOT_NOT_CONVERGED: "first-contact search did not converge (ROOT_MAX_STEPS reached)",
    NON_FINITE: "non-finite value in the state (NaN or infinity)",
    BAD_STATE: "initial state not allowed (below the floor or moving into it)",
}

FAILURES = (ROOT_NOT_CONVERGED, NON_FINITE, BAD_STATE)


class SimulationError(RuntimeError):
    """A kernel returned a failure status."""


def raise_for_status(status: int, where: str) -> None:
    """Raise ``SimulationError`` naming ``where`` if ``status`` is a failure."""
    if status in FAILURES:
        raise SimulationError(f"{where}: {STATUS_MESSAGES[status]} (status {status})")


#: Fast-forward modes of the ensemble (``bbdyn.ensemble.ensemble``, ``bbdyn simulate``):
#: skip converged or bitwise repeating stick-release cycles, or none (``core.ensemble``).
FAST_FORWARD_MODES = ("converged", "bitwise", "off")
