"""Periodic orbits, their stability and the Arnold tongues of the flat ball (docs/model.md §1).

The exact impact map ``P: (theta, vrel) -> (theta', vrel')`` takes the phase
``theta = w t mod 2 pi`` of an impact and the relative velocity ``vrel = v - u``
just after it to the next impact (``bbdyn.core.flat.flat_flight``, then
``vrel' = -alpha vrel-``).  This module gives

* the k/1 orbit (flight time ``2 pi k / w``) in closed form, and the tongue
  edges of Luck & Mehta, derived in ``derivations/flat_tongues.py``;
* the Jacobian of the exact map at any state (implicit function theorem on the
  gap equation, valid for any flight), its chain over m impacts, eigenvalues;
* a Newton solver for k/m orbits (k driving periods in m impacts);
* the tongue edges found numerically from the eigenvalues along computed
  orbits: ``gamma_lo`` where the orbit is born in a saddle-node (eigenvalue +1,
  at ``cos theta* = -1``) and ``gamma_hi`` where an eigenvalue crosses -1.

The closed forms take ``xp`` (the ``math``, ``numpy`` or ``sympy`` module), so
the test of the derivation compares the very expressions used here with the
derived ones.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from bbdyn.core.flat import flat_event
from bbdyn.core.flat_jacobian import flat_map_jacobian
from bbdyn.core.plate import TWO_PI, advance_phase
from bbdyn.core.status import IMPACT, OK, STATUS_MESSAGES
from bbdyn.core.tolerances import (
    BOUNDARY_RTOL,
    FD_STEP_REL,
    ORBIT_NEWTON_MAX_ITER,
    ORBIT_NEWTON_TOL,
)
from bbdyn.params import Params
from bbdyn.results import Result, make_meta

__all__ = [
    "K1Orbit",
    "OrbitNotFound",
    "PeriodicOrbit",
    "TongueTable",
    "find_periodic_orbit",
    "frequency_at_gamma",
    "gamma_hi_numeric",
    "gamma_lo_numeric",
    "k1_cos_phase",
    "k1_orbit",
    "k1_orbit_numeric",
    "k1_trace",
    "k1_velocity",
    "map_jacobian",
    "params_at_gamma",
    "tongue_gamma_hi",
    "tongue_gamma_lo",
    "tongue_table",
]


# ---- closed forms (derivations/flat_tongues.py) ----------------------------------------------
def tongue_gamma_lo(k, alpha, xp=math):
    """Lower tongue edge ``Gamma_lo = pi k (1 - alpha) / (1 + alpha)`` (saddle-node)."""
    return xp.pi * k * (1 - alpha) / (1 + alpha)


def tongue_gamma_hi(k, alpha, xp=math):
    """Upper tongue edge (period doubling, docs/model.md, Luck & Mehta 1993).

    ``Gamma_hi = sqrt(Gamma_lo^2 + [2 (1 + alpha^2) / (1 + alpha)^2]^2)``, which is
    docs/model.md's ``pi sqrt([k (1-alpha)/(1+alpha)]^2 + [2 (1+alpha^2) / (pi (1+alpha)^2)]^2)``.
    """
    return xp.sqrt(
        tongue_gamma_lo(k, alpha, xp) ** 2 + (2 * (1 + alpha**2) / (1 + alpha) ** 2) ** 2
    )


def k1_cos_phase(k, gamma, alpha, xp=math):
    """``cos theta*`` of the k/1 impact phase: ``-pi k (1 - alpha) / ((1 + alpha) Gamma)``."""
    return -tongue_gamma_lo(k, alpha, xp) / gamma


def k1_velocity(k, w, g, alpha, xp=math):
    """Post-impact velocities of the k/1 orbit (mm/s): absolute ``v = g pi k / w`` and
    relative ``vrel = v - u = 2 alpha g pi k / ((1 + alpha) w)``."""
    v = g * xp.pi * k / w
    return v, 2 * alpha * v / (1 + alpha)


def k1_trace(gamma, alpha, sin_phase):
    """Trace of the k/1 Jacobian, ``1 + alpha^2 + (1 + alpha)^2 Gamma sin theta*``.

    Its determinant is ``alpha^2`` for every flight (see ``map_jacobian``), so the
    multipliers are +1 at ``sin theta* = 0`` and -1 at
    ``Gamma sin theta* = -2 (1 + alpha^2) / (1 + alpha)^2``.
    """
    return 1 + alpha**2 + (1 + alpha) ** 2 * gamma * sin_phase


class K1Orbit(NamedTuple):
    """The k/1 orbit in closed form (units mm, s, rad).

    ``phase_stable`` has ``sin < 0`` (in ``[pi, 3 pi / 2]``), the candidate stable
    orbit; ``phase_unstable`` has ``sin > 0`` (a saddle).  Both have the same
    velocities.  For ``alpha = 0``, ``vrel = 0``: the ball sticks unless the plate
    accelerates downward faster than g there.
    """

    k: int
    tau: float
    v: float
    vrel: float
    cos_phase: float
    phase_stable: float
    phase_unstable: float


def _check_k(name: str, k) -> int:
    if isinstance(k, bool) or not isinstance(k, int | np.integer) or k < 1:
        raise ValueError(f"{name} must be an integer >= 1, got {k!r}")
    return int(k)


def k1_orbit(params: Params, k: int) -> K1Orbit:
    """The k/1 orbit of the exact map at ``params``, in closed form.

    Raises ``ValueError`` below the tongue's lower edge, where it does not exist.

    Examples
    --------
    >>> o = k1_orbit(Params(f=58.0), 1)
    >>> round(o.tau * 58.0, 12), o.phase_stable > math.pi
    (1.0, True)
    """
    k = _check_k("k", k)
    lo = tongue_gamma_lo(k, params.alpha)
    if params.gamma < lo:
        raise ValueError(
            f"Gamma must be >= Gamma_lo = {lo:.12g} for a {k}/1 orbit, got {params.gamma:.12g}"
        )
    c = max(-1.0, k1_cos_phase(k, params.gamma, params.alpha))
    v, vrel = k1_velocity(k, params.w, params.g, params.alpha)
    theta = math.acos(c)
    return K1Orbit(k, k * TWO_PI / params.w, v, vrel, c, TWO_PI - theta, theta)


def frequency_at_gamma(gamma, A: float = 0.1, g: float = 9800.0):
    """Driving frequency (Hz) at which ``A w^2 / g = Gamma``."""
    return np.sqrt(np.asarray(gamma) * g / A) / TWO_PI


def params_at_gamma(gamma: float, *, alpha: float, A: float = 0.1, g: float = 9800.0) -> Params:
    """Flat-ball ``Params`` with the given Gamma (frequency chosen at fixed A, g)."""
    if not (math.isfinite(gamma) and gamma > 0):
        raise ValueError(f"gamma must be > 0, got {gamma}")
    if not A > 0:
        raise ValueError(f"A must be > 0 mm to set Gamma by the frequency, got {A}")
    return Params(f=float(frequency_at_gamma(gamma, A, g)), A=A, g=g, alpha=alpha)


# ---- Jacobian of the exact map: bbdyn.core.flat_jacobian.flat_map_jacobian ------------
def map_jacobian(params: Params, phase: float, vrel: float) -> np.ndarray:
    """Jacobian (2, 2) of the exact map at ``(phase, vrel)`` (rad, mm/s), lifted phase.

    Its determinant is ``alpha vrel / (-vrel-)`` (flux conservation of the flight
    times the impact's ``-alpha``); on a k/1 orbit that is ``alpha^2``.
    """
    phase, vrel = _check_state(phase, vrel)
    _, _, jac, status = flat_map_jacobian(phase, vrel, params.kernel())
    if status != OK:
        raise OrbitNotFound(
            f"map_jacobian at phase {phase}, vrel {vrel}: {STATUS_MESSAGES[status]}"
        )
    return jac


def _check_state(phase, vrel) -> tuple[float, float]:
    phase, vrel = float(phase), float(vrel)
    if not math.isfinite(phase):
        raise ValueError(f"phase must be finite, got {phase}")
    if not (math.isfinite(vrel) and vrel > 0):
        raise ValueError(f"vrel must be > 0 mm/s, got {vrel}")
    return phase % TWO_PI, vrel


# ---- periodic orbits -----------------------------------------------------------------------
class OrbitNotFound(RuntimeError):
    """The Newton solver for a periodic orbit failed; the message says where and why."""


class PeriodicOrbit(Result):
    """A k/m orbit of the exact flat map: k driving periods in m impacts.

    Arrays: ``phase`` (m,) impact phases (rad), ``vrel`` (m,) relative velocities
    after them (mm/s), ``tau`` (m,) flight times (s), ``jacobian`` (2, 2) of the
    m-fold map at ``phase[0]``, ``eigenvalues`` (2,) complex multipliers.
    Meta: ``k``, ``m``, ``iterations``, ``residual``, params.
    """

    kind = "flat_periodic_orbit"

    @property
    def eigenvalues(self) -> np.ndarray:
        return self.arrays["eigenvalues"]

    @property
    def is_stable(self) -> bool:
        """All multipliers strictly inside the unit circle."""
        return bool(np.max(np.abs(self.eigenvalues)) < 1.0)

    def plot(self, ax=None):
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots()
        ax.plot(self["phase"], self["vrel"], "o")
        ax.set(xlabel="impact phase (rad)", ylabel="vrel after impact (mm/s)")
        ax.set_title(f"{self.meta['k']}/{self.meta['m']} orbit")
        return ax


def _chain(z, k, m, kp):
    """Residual ``(sum w tau_i - 2 pi k, vrel_m - vrel_0)`` and the m-fold Jacobian."""
    phase, vrel = z
    jac = np.eye(2)
    phases, vrels, taus = np.empty(m), np.empty(m), np.empty(m)
    total = 0.0
    for i in range(m):
        phases[i], vrels[i] = phase, vrel
        dphase, vrel, jac_i, status = flat_map_jacobian(phase, vrel, kp)
        if status != OK:
            raise OrbitNotFound(
                f"flight {i} of the {k}/{m} orbit from phase {phase:.17g}, vrel {vrel:.17g}: "
                f"{STATUS_MESSAGES[status]}"
            )
        if not vrel > 0.0:
            raise OrbitNotFound(f"impact {i} of the {k}/{m} orbit leaves vrel = {vrel} (sticks)")
        taus[i] = dphase / kp.w
        total += dphase
        jac = jac_i @ jac
        _, phase = advance_phase(0.0, phase, dphase)
    residual = np.array([total - TWO_PI * k, vrel - z[1]])
    return residual, jac, (phases, vrels, taus)


def _newton(fun, z, scale, max_step, what):
    """Damped Newton on ``fun(z) -> (residual, jacobian, extra)``.

    Converged when ``max|residual / scale| <= ORBIT_NEWTON_TOL``; each step is
    shrunk so that ``|dz_i| <= max_step(z)_i``.  Returns ``(z, extra, iterations,
    residual)`` or raises ``OrbitNotFound`` naming ``what``, the last state and residual.
    """
    z = np.array(z, dtype=float)
    res = math.inf
    for it in range(ORBIT_NEWTON_MAX_ITER + 1):
        R, jac, extra = fun(z)
        res = float(np.max(np.abs(R) / scale))
        if res <= ORBIT_NEWTON_TOL:
            return z, extra, it, res
        if it == ORBIT_NEWTON_MAX_ITER:
            break
        try:
            step = np.linalg.solve(jac, -R)
        except np.linalg.LinAlgError:
            raise OrbitNotFound(
                f"{what}: singular Newton matrix at {z.tolist()} (a multiplier is +1: a fold)"
            ) from None
        shrink = float(np.min(max_step(z) / np.maximum(np.abs(step), 1e-300)))
        z = z + min(1.0, shrink) * step
    raise OrbitNotFound(
        f"{what}: Newton did not converge in {ORBIT_NEWTON_MAX_ITER} iterations; "
        f"last state {z.tolist()}, scaled residual {res:.3g} > {ORBIT_NEWTON_TOL:.3g}"
    )


def find_periodic_orbit(params: Params, k: int, m: int, phase: float, vrel: float) -> PeriodicOrbit:
    """Newton solve for a k/m orbit of the exact map (k periods, m impacts).

    Unknowns are the first impact ``(phase, vrel)``; the residual is
    ``(sum of the m flight phases - 2 pi k, vrel_m - vrel_0)`` computed with the
    exact first-contact kernel, and its Jacobian is ``J_m ... J_1 - I`` from
    ``flat_map_jacobian``.  The solution is then replayed through
    ``core.flat.flat_event`` to confirm that the simulator follows it (no
    chattering, no sticking).

    Parameters
    ----------
    params : Params
    k, m : int
        Driving periods and impacts per orbit period (>= 1).
    phase, vrel : float
        Starting guess (rad, mm/s; vrel > 0).

    Returns
    -------
    PeriodicOrbit

    Raises
    ------
    OrbitNotFound
        With the reason: no convergence, a fold (multiplier +1), a grazing or
        failing flight, or an impact that sticks.
    """
    k, m = _check_k("k", k), _check_k("m", m)
    phase, vrel = _check_state(phase, vrel)
    kp = params.kernel()
    # velocity scale: the launch speed of a k-period flight (vrel alone may be tiny)
    scale = np.array([TWO_PI * k, vrel + kp.g * kp.period * k])

    def fun(z):
        R, jac, extra = _chain(z, k, m, kp)
        return R, jac - np.eye(2), (jac, extra)

    def max_step(z):
        return np.array([0.5, 0.5 * z[1]])

    z, (jac, (phases, vrels, taus)), iterations, res = _newton(
        fun, [phase, vrel], scale, max_step, f"{k}/{m} orbit at Gamma = {params.gamma:.12g}"
    )
    _replay(phases, vrels, kp, k, m)
    return PeriodicOrbit(
        {
            "phase": phases,
            "vrel": vrels,
            "tau": taus,
            "jacobian": jac,
            "eigenvalues": np.linalg.eigvals(jac).astype(complex),
        },
        make_meta(params, k=k, m=m, iterations=iterations, residual=res),
    )


def _replay(phases, vrels, kp, k, m):
    """Check the simulator's event map follows the orbit: m impacts, k periods, closes."""
    periods, phase, vrel = 0.0, phases[0], vrels[0]
    for i in range(m):
        periods, phase, vrel, kind, status = flat_event(periods, phase, vrel, IMPACT, kp)
        if status != OK or kind != IMPACT:
            raise OrbitNotFound(
                f"{k}/{m} orbit: the simulator's event {i} is not an impact "
                f"(kind {kind}, status {STATUS_MESSAGES.get(status, status)})"
            )
    if abs(periods + (phase - phases[0]) / TWO_PI - k) > 1e3 * ORBIT_NEWTON_TOL * k:
        raise OrbitNotFound(f"{k}/{m} orbit: the simulator's replay does not close")


# ---- tongue edges from the eigenvalues ------------------------------------------------------
def _check_alpha_numeric(alpha: float) -> float:
    alpha = float(alpha)
    if not 0.0 < alpha <= 1.0:
        raise ValueError(
            "alpha must be in (0, 1] for the numeric tongue edges (at alpha = 0 the k/1 "
            f"orbit leaves with vrel = 0 and sticks), got {alpha}"
        )
    return alpha


def k1_orbit_numeric(
    k: int, gamma: float, alpha: float, A: float = 0.1, g: float = 9800.0, guess=None
) -> PeriodicOrbit:
    """The stable-branch k/1 orbit at Gamma found by Newton on the exact map.

    The closed form only supplies the starting guess (unless ``guess = (phase, vrel)``).
    """
    params = params_at_gamma(gamma, alpha=alpha, A=A, g=g)
    if guess is None:
        o = k1_orbit(params, k)
        guess = (o.phase_stable, o.vrel)
    return find_periodic_orbit(params, k, 1, *guess)


def gamma_hi_numeric(k: int, alpha: float, A: float = 0.1, g: float = 9800.0) -> float:
    """Upper tongue edge from the exact map: where a multiplier of the k/1 orbit is -1.

    Marches up in Gamma from just above the lower edge, solving the stable-branch
    orbit by Newton on the exact map at each Gamma (the closed form is only the
    starting guess), until ``det(J + I) = (1 + l1)(1 + l2)`` changes sign, then
    ``brentq`` on it.
    """
    from scipy.optimize import brentq

    k, alpha = _check_k("k", k), _check_alpha_numeric(alpha)
    lo = tongue_gamma_lo(k, alpha)
    step = 0.05 * max(lo, 1.0)

    def det_j_plus_i(gamma):
        orbit = k1_orbit_numeric(k, gamma, alpha, A, g)
        return float(np.linalg.det(orbit["jacobian"] + np.eye(2)))

    a = lo + 0.5 * step
    fa = det_j_plus_i(a)
    for _ in range(40):  # narrow tongues (small alpha, large k): start closer to the fold
        if fa > 0.0:
            break
        step *= 0.25
        a = lo + 0.5 * step
        fa = det_j_plus_i(a)
    for _ in range(1000):
        b = a + step
        fb = det_j_plus_i(b)
        if fa > 0.0 >= fb:
            return brentq(det_j_plus_i, a, b, xtol=1e-300, rtol=BOUNDARY_RTOL)
        a, fa = b, fb
    raise OrbitNotFound(f"no period-doubling of the {k}/1 orbit found up to Gamma = {b:.6g}")


def _k1_at_phase(k, theta, alpha, A, g, guess_gamma):
    """Solve for (Gamma, V = vrel w / g) such that the k/1 orbit has impact phase theta."""

    def fun(z):
        gamma, V = z
        kp = params_at_gamma(gamma, alpha=alpha, A=A, g=g).kernel()
        R, jac, _ = _chain((theta, V * g / kp.w), k, 1, kp)
        h = FD_STEP_REL * gamma
        cols = []
        for sign in (1.0, -1.0):
            kph = params_at_gamma(gamma + sign * h, alpha=alpha, A=A, g=g).kernel()
            Rh, _, _ = _chain((theta, V * g / kph.w), k, 1, kph)
            cols.append(Rh * np.array([1.0, kph.w / g]))
        dR_dgamma = (cols[0] - cols[1]) / (2.0 * h)
        # V columns: d(x)/dV = J01 g / w, d(V' - V)/dV = J11 - 1
        dR_dV = np.array([jac[0, 1] * g / kp.w, jac[1, 1] - 1.0])
        R_scaled = R * np.array([1.0, kp.w / g])
        return R_scaled, np.column_stack([dR_dgamma, dR_dV]), (kp, jac)

    V0 = 2 * alpha * math.pi * k / (1 + alpha)
    z, (kp, jac), _, _ = _newton(
        fun,
        [guess_gamma, V0],
        np.array([TWO_PI * k, V0]),
        lambda z: np.array([0.1 * z[0], 0.5 * z[1]]),
        f"{k}/1 orbit at phase {theta:.12g}",
    )
    return z[0], jac


def gamma_lo_numeric(k: int, alpha: float, A: float = 0.1, g: float = 9800.0) -> float:
    """Lower tongue edge from the exact map: the saddle-node where a multiplier is +1.

    At a fold Newton in ``(phase, vrel)`` is singular, so the branch of k/1 orbits
    is parametrized by its impact phase theta instead: for each theta Newton
    solves the exact map for ``(Gamma, vrel)`` (the Gamma column by central
    differences), and ``brentq`` finds the theta where ``det(J - I) = 0``.  Gamma
    is stationary there, so its value is accurate to rounding.  Returns ``nan``
    for ``alpha = 1``, where the orbit exists for every Gamma > 0 (edge at 0).
    """
    from scipy.optimize import brentq

    k, alpha = _check_k("k", k), _check_alpha_numeric(alpha)
    if alpha == 1.0:
        return math.nan
    lo = tongue_gamma_lo(k, alpha)
    found = {}

    def det_j_minus_i(theta):
        # closed form only as Newton's starting point
        guess = lo / max(-math.cos(theta), 0.5)
        gamma, jac = _k1_at_phase(k, theta, alpha, A, g, guess)
        found[theta] = gamma
        return float(np.linalg.det(jac - np.eye(2)))

    # For small alpha the saddle branch (theta < pi) is virtual a little away from
    # the fold (the slow ball meets the rising plate early), so the bracket shrinks.
    for half in (0.25, 0.1, 0.03, 0.01):
        try:
            ends = (det_j_minus_i(math.pi - half), det_j_minus_i(math.pi + half))
        except OrbitNotFound:
            continue
        if ends[0] * ends[1] < 0:
            theta = brentq(
                det_j_minus_i, math.pi - half, math.pi + half, xtol=1e-14, rtol=BOUNDARY_RTOL
            )
            det_j_minus_i(theta)
            return found[theta]
    raise OrbitNotFound(f"no fold of the {k}/1 orbit found near phase pi (alpha = {alpha})")


# ---- the table of tongues -------------------------------------------------------------------
class TongueTable(Result):
    """k/1 tongue edges in Gamma and in frequency, closed form and numeric.

    Arrays (one entry per k): ``k``, ``gamma_lo``, ``gamma_hi`` (closed form),
    ``gamma_lo_numeric``, ``gamma_hi_numeric`` (eigenvalues of the exact map),
    ``f_lo_hz``, ``f_hi_hz`` (closed form at the meta's A and g).
    """

    kind = "flat_tongues"
    FIELDS = (
        "k",
        "gamma_lo",
        "gamma_hi",
        "gamma_hi_numeric",
        "gamma_lo_numeric",
        "f_lo_hz",
        "f_hi_hz",
    )

    def rows(self) -> list[dict]:
        """One dict per k (JSON-ready: NaN becomes None)."""
        out = []
        for i in range(len(self["k"])):
            row = {}
            for name in self.FIELDS:
                value = self[name][i].item()
                row[name] = None if isinstance(value, float) and math.isnan(value) else value
            out.append(row)
        return out

    def plot(self, ax=None):
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots()
        for k, lo, hi in zip(self["k"], self["gamma_lo"], self["gamma_hi"], strict=True):
            ax.axvspan(lo, hi, alpha=0.3)
            ax.text(0.5 * (lo + hi), 0.5, f"{k}/1", ha="center")
        ax.plot(self["gamma_lo_numeric"], np.full(len(self["k"]), 0.4), "k|", ms=20)
        ax.plot(self["gamma_hi_numeric"], np.full(len(self["k"]), 0.4), "k|", ms=20)
        ax.set(xlabel="Gamma", yticks=[], title=f"k/1 tongues, alpha = {self.meta['alpha']}")
        return ax


def tongue_table(
    alpha: float = 0.5, kmax: int = 3, A: float = 0.1, g: float = 9800.0, numeric: bool = True
) -> TongueTable:
    """Tongue edges for k = 1..kmax: closed form, numeric (if ``numeric``) and in Hz.

    Examples
    --------
    >>> t = tongue_table(0.5, 1, numeric=False)
    >>> round(float(t["f_lo_hz"][0]), 2), round(float(t["f_hi_hz"][0]), 2)
    (50.99, 61.56)
    """
    import time

    start = time.perf_counter()
    Params(f=1.0, A=A, g=g, alpha=alpha)  # validates A, g, alpha
    kmax = _check_k("kmax", kmax)
    if A == 0:
        raise ValueError(f"A must be > 0 mm for tongues in frequency, got {A}")
    ks = np.arange(1, kmax + 1)
    lo = np.array([tongue_gamma_lo(k, alpha) for k in ks])
    hi = np.array([tongue_gamma_hi(k, alpha) for k in ks])
    nan = np.full(kmax, np.nan)
    lo_num = np.array([gamma_lo_numeric(k, alpha, A, g) for k in ks]) if numeric else nan
    hi_num = np.array([gamma_hi_numeric(k, alpha, A, g) for k in ks]) if numeric else nan
    return TongueTable(
        {
            "k": ks,
            "gamma_lo": lo,
            "gamma_hi": hi,
            "gamma_lo_numeric": lo_num,
            "gamma_hi_numeric": hi_num,
            "f_lo_hz": frequency_at_gamma(lo, A, g),
            "f_hi_hz": frequency_at_gamma(hi, A, g),
        },
        make_meta(wall_s=time.perf_counter() - start, alpha=alpha, A=A, g=g, kmax=kmax),
    )


def tongue_intervals(params: Params, f_lo: float, f_hi: float, kmax: int = 6) -> np.ndarray:
    """k/1 tongue intervals of the flat ball (closed form) meeting ``[f_lo, f_hi]``, Hz.

    Returns
    -------
    array, shape (m, 3)
        Rows ``(k, f_start, f_stop)``.
    """
    table = tongue_table(params.alpha, kmax, params.A, params.g, numeric=False)
    rows = [
        (float(k), float(a), float(b))
        for k, a, b in zip(table["k"], table["f_lo_hz"], table["f_hi_hz"], strict=True)
        if b >= f_lo and a <= f_hi
    ]
    return np.array(rows).reshape(-1, 3)
