"""Continuation of periodic orbits of the exact flat impact map in Gamma (docs/higher_tongues.md).

The exact map depends on ``(Gamma, alpha)`` only, so this module works in the
dimensionless units ``g = w = 1`` (plate amplitude ``A = Gamma``): time is the
phase ``theta = w t`` (rad), velocities are ``V = vrel w / g``.  A k/m orbit
(k driving periods in m impacts) is a zero of

    R(theta, V, Gamma) = (Theta_m - theta - 2 pi k, V_m - V)

where ``(Theta_i, V_i)`` are the lifted phase and velocity after i impacts of
``bbdyn.core.flat_jacobian.flat_map_jacobian`` (the simulator's first-contact
kernel).  Its derivatives are exact: ``M - I`` in ``(theta, V)`` (``M`` the
monodromy matrix, the product of the one-impact Jacobians) and, in Gamma, the
implicit function theorem on the gap (``_gamma_column``).

Branches are followed by pseudo-arclength continuation in ``x = (theta, V, Gamma)``
(secant-free: the tangent is the null vector of ``[M - I | dR/dGamma]``) with step
control, so they pass folds.  Along a branch the test functions ``det(M - I)``
(multiplier +1: saddle-node) and ``det(M + I)`` (multiplier -1: period doubling)
are watched; a sign change is located by ``brentq`` in the arclength on the
corrected branch, to ``BIF_XTOL`` in arclength (Gamma at a fold is stationary, at
a flip it moves by at most ``|dGamma/ds|`` times that).

A branch ends with a ``status`` and a ``reason``:

* ``"gamma_range"`` / ``"flip"`` / ``"max_steps"``: asked-for ends;
* ``"chatter"``: the replay of an orbit point through ``core.flat.flat_event``
  (the simulator) sticks, i.e. an impact velocity is below the chattering
  threshold: the orbit does not exist as a sequence of free flights;
* ``"grazing"``: the continued orbit's flight would cut through the plate: the
  first contact of the exact kernel jumps to an earlier contact (a flight phase
  changes by more than ``FLIGHT_JUMP`` rad in a step that cannot be refined), or
  lands tangentially (``vrel- = 0``);
* ``"replay"``: the simulator leaves the orbit (its events differ by more than
  ``REPLAY_TOL``) without sticking;
* ``"newton"``: the corrector fails at the smallest step for another reason.
"""

from __future__ import annotations

import math
from math import gcd
from typing import NamedTuple

import numpy as np

from bbdyn.core.flat import FlatArrays, FlatState, flat_event, flat_run
from bbdyn.core.flat_jacobian import flat_map_jacobian
from bbdyn.core.plate import TWO_PI, sin_minus_x
from bbdyn.core.status import IMPACT, NON_FINITE, OK, STATUS_MESSAGES
from bbdyn.core.tolerances import ORBIT_NEWTON_TOL
from bbdyn.flat.tongues import k1_cos_phase, tongue_gamma_hi, tongue_gamma_lo
from bbdyn.params import Params
from bbdyn.results import Result, make_meta

__all__ = [
    "Bifurcation",
    "Branch",
    "CascadeTable",
    "bifurcation_diagram",
    "OrbitLost",
    "continue_branch",
    "doubling_cascade",
    "feigenbaum_ratios",
    "km_orbit_guesses",
    "km_regions",
    "cascade",
    "k1_start",
    "switch_at_flip",
    "orbit_chain",
    "unit_kernel",
]

#: Newton iterations of the corrector before the step is halved.
CORRECTOR_MAX_ITER = 12
#: Arclength accuracy of a located bifurcation point (dimensionless, x = (theta, V, Gamma)).
BIF_XTOL = 1e-14
#: A flight phase changing by more than this (rad) in one step is a jump of the first contact.
FLIGHT_JUMP = 0.3
#: A flight whose interior gap falls below this fraction of its height scale grazes the plate.
GRAZE_REL = 1e-3
#: Replay of an orbit through the simulator: largest phase (rad) plus relative V deviation.
REPLAY_TOL = 1e-9
#: Largest corrector step (dimensionless): a longer one has left the branch's neighbourhood.
MAX_NEWTON_STEP = 0.5
#: Continuation steps per cascade level (about 15 are needed; a level that needs far more
#: has lost its branch, and its cost grows as 2^n impacts per step).
CASCADE_MAX_STEPS = 300
#: A cascade level must double within this many times the previous level's Gamma interval
#: (the expected distance is 1 / 4.67 of it); a branch that goes further has missed it.
CASCADE_REACH = 2.0
#: Feigenbaum's constant (period doubling of one-hump maps, and of area-contracting maps).
FEIGENBAUM_DELTA = 4.669201609102990


class OrbitLost(RuntimeError):
    """The corrector failed; ``status`` is ``"grazing"``, ``"chatter"`` or ``"newton"``."""

    def __init__(self, status: str, message: str):
        super().__init__(message)
        self.status = status


def unit_kernel(gamma: float, alpha: float):
    """Kernel parameters in units ``g = w = 1`` (``A = Gamma``): the map at ``(Gamma, alpha)``."""
    return Params(f=1.0 / TWO_PI, A=float(gamma), g=1.0, alpha=float(alpha)).kernel()


def _gamma_column(theta, x, v_minus, gamma, alpha):
    """d(x, V')/dGamma of one impact at fixed ``(theta, V)`` (implicit function theorem).

    Gap ``G = V x - x^2 / 2 - Gamma r(x)`` with ``r = 2 s0 sin^2(x/2) - c0 (sin x - x)``,
    ``G' = V - x - Gamma d(x)`` with ``d = 2 c0 sin^2(x/2) + s0 sin x``, ``G'' = -1 -
    Gamma sin(theta + x)``; ``dx/dGamma = r / G'``, ``V' = -alpha G'``.
    """
    s0, c0 = math.sin(theta), math.cos(theta)
    sh = math.sin(0.5 * x)
    r = 2.0 * s0 * sh * sh - c0 * sin_minus_x(x)
    d = 2.0 * c0 * sh * sh + s0 * math.sin(x)
    dx = r / v_minus
    return dx, alpha * (d + (1.0 + gamma * math.sin(theta + x)) * dx)


class Chain(NamedTuple):
    """One pass around a candidate k/m orbit (dimensionless).

    ``residual`` (2,), ``monodromy`` (2, 2), ``d_gamma`` (2,) = dR/dGamma, per impact
    ``theta`` (m,) (mod 2 pi), ``V`` (m,) after it, ``flight`` (m,) phase advances, and
    ``det`` = det(monodromy) as the product of the one-impact determinants (accurate
    where the product matrix is nearly singular and its own determinant is rounding).
    """

    residual: np.ndarray
    monodromy: np.ndarray
    d_gamma: np.ndarray
    theta: np.ndarray
    V: np.ndarray
    flight: np.ndarray
    det: float


def orbit_chain(theta: float, V: float, gamma: float, k: int, m: int, alpha: float) -> Chain:
    """Residual and exact derivatives of the k/m orbit condition at ``(theta, V, Gamma)``.

    Raises ``OrbitLost`` (status ``"grazing"`` for a tangential landing, ``"newton"``
    otherwise) when a flight fails or an impact leaves ``V <= 0``.
    """
    kp = unit_kernel(gamma, alpha)
    jac, col, det = np.eye(2), np.zeros(2), 1.0
    th, v = theta % TWO_PI, V
    thetas, vs, flights = np.empty(m), np.empty(m), np.empty(m)
    for i in range(m):
        thetas[i], vs[i] = th, v
        x, v_new, j, status = flat_map_jacobian(th, v, kp)
        if status != OK or not v_new > 0.0:
            kind = "grazing" if status == NON_FINITE else "newton"
            why = STATUS_MESSAGES[status] if status != OK else f"leaves V = {v_new}"
            raise OrbitLost(kind, f"flight {i} of the {k}/{m} orbit at Gamma = {gamma!r}: {why}")
        b = _gamma_column(th, x, -v_new / alpha, gamma, alpha)
        jac = j @ jac
        det *= j[0, 0] * j[1, 1] - j[0, 1] * j[1, 0]
        col = j @ col + np.array(b)
        flights[i] = x
        th, v = (th + x) % TWO_PI, v_new
    total = float(np.sum(flights))
    residual = np.array([total - TWO_PI * k, v - V])
    return Chain(residual, jac, col, thetas, vs, flights, det)


def _scale(k: int, V: float) -> np.ndarray:
    """Residual scales: 2 pi k (phase) and the launch speed V + 2 pi k (as bbdyn.flat.tongues)."""
    return np.array([TWO_PI * k, abs(V) + TWO_PI * k])


def _replay_ok(chain: Chain, gamma: float, alpha: float, k: int, m: int) -> tuple[str, str]:
    """``("", "")`` if the simulator (``flat_event``) follows the orbit for m impacts (every
    event an impact, at the orbit's next phase (rad) and V (relative) to REPLAY_TOL), else
    ``(status, why)`` with status ``"chatter"`` (a stick) or ``"replay"``."""
    kp = unit_kernel(gamma, alpha)
    periods, th, v = 0.0, chain.theta[0], chain.V[0]
    for i in range(m):
        periods, th, v, kind, status = flat_event(periods, th, v, IMPACT, kp)
        if status != OK:
            return "replay", f"event {i}: {STATUS_MESSAGES[status]}"
        if kind != IMPACT:
            vin = chain.V[(i + 1) % m] / alpha
            return "chatter", (
                f"impact {i + 1} of the {k}/{m} orbit at Gamma = {gamma:.12g} sticks "
                f"(arrival speed {vin:.3g} g/w is below the chattering threshold)"
            )
        j = (i + 1) % m
        off = abs(math.remainder(th - chain.theta[j], TWO_PI)) + abs(v - chain.V[j]) / chain.V[j]
        if off > REPLAY_TOL:
            return "replay", f"event {i + 1}: the simulator leaves the {k}/{m} orbit by {off:.2g}"
    return "", ""


class Point(NamedTuple):
    """A corrected branch point: ``x = (theta, V, Gamma)``, its chain and unit tangent."""

    x: np.ndarray
    chain: Chain
    tangent: np.ndarray


def _tangent(chain: Chain, previous: np.ndarray | None) -> np.ndarray:
    """Unit null vector of ``[M - I | dR/dGamma]``, oriented along ``previous``."""
    a = np.column_stack([chain.monodromy - np.eye(2), chain.d_gamma])
    t = np.cross(a[0], a[1])
    t /= np.linalg.norm(t)
    if previous is not None and float(t @ previous) < 0.0:
        t = -t
    return t


def _correct(x_pred, t, k, m, alpha) -> tuple[np.ndarray, Chain, int]:
    """Newton on ``(R(x), t . (x - x_pred)) = 0``; returns ``(x, chain, iterations)``."""
    x = np.array(x_pred, dtype=float)
    polish = False
    for it in range(CORRECTOR_MAX_ITER + 1):
        if not x[1] > 0.0 or not x[2] > 0.0:
            raise OrbitLost("newton", f"corrector left V > 0, Gamma > 0: {x.tolist()}")
        ch = orbit_chain(x[0], x[1], x[2], k, m, alpha)
        res = float(np.max(np.abs(ch.residual) / _scale(k, x[1])))
        if res <= ORBIT_NEWTON_TOL and (polish or res == 0.0):
            return x, ch, it
        polish = res <= ORBIT_NEWTON_TOL  # one more step: quadratic convergence to rounding
        a = np.vstack([np.column_stack([ch.monodromy - np.eye(2), ch.d_gamma]), t])
        rhs = -np.concatenate([ch.residual, [float(t @ (x - x_pred))]])
        try:
            step = np.linalg.solve(a, rhs)
        except np.linalg.LinAlgError:
            break
        if not np.max(np.abs(step)) <= MAX_NEWTON_STEP:
            break
        x = x + step
    raise OrbitLost("newton", f"corrector did not converge from {np.asarray(x_pred).tolist()}")


def _correct_at_gamma(theta, V, gamma, k, m, alpha) -> Point:
    """Newton at fixed Gamma (a starting point), with the tangent of the branch there."""
    x, ch, _ = _correct([theta, V, gamma], np.array([0.0, 0.0, 1.0]), k, m, alpha)
    return Point(x, ch, _tangent(ch, None))


def _tests(ch: Chain) -> tuple[float, float]:
    """Test functions ``det(M - I) = 1 - tr M + det M`` (fold, +1) and ``det(M + I) =
    1 + tr M + det M`` (flip, -1), with ``det M`` from ``Chain.det``: deep in a cascade
    M is nearly singular and ``np.linalg.det(M +- I)`` would lose it to rounding."""
    tr = float(np.trace(ch.monodromy))
    return 1.0 - tr + ch.det, 1.0 + tr + ch.det


def _multipliers(ch: Chain) -> np.ndarray:
    """The two multipliers (complex) from ``tr M`` and ``Chain.det``."""
    half = 0.5 * complex(np.trace(ch.monodromy))
    root = np.sqrt(half * half - ch.det)
    big = half + root if half.real >= 0 else half - root  # no cancellation
    small = ch.det / big if big != 0 else half
    return np.array([big, small])


class Bifurcation(NamedTuple):
    """A located bifurcation: ``kind`` ("fold" or "flip"), ``gamma``, state, eigenvector."""

    kind: str
    gamma: float
    theta: float
    V: float
    eigvec: np.ndarray


def _locate(p: Point, ds: float, which: int, k, m, alpha) -> Bifurcation:
    """Root of test function ``which`` (0 fold, 1 flip) on the branch between p and p + ds."""
    from scipy.optimize import brentq

    def phi(s):
        x, ch, _ = _correct(p.x + s * p.tangent, p.tangent, k, m, alpha)
        return _tests(ch)[which]

    s = brentq(phi, 0.0, ds, xtol=BIF_XTOL, rtol=4 * np.finfo(float).eps)
    x, ch, _ = _correct(p.x + s * p.tangent, p.tangent, k, m, alpha)
    return _bifurcation(which, x, ch)


def _bifurcation(which: int, x, ch: Chain) -> Bifurcation:
    """The Bifurcation at ``x`` with the eigenvector of the multiplier +1 (0) or -1 (1)."""
    w, vecs = np.linalg.eig(ch.monodromy)
    vec = np.real(vecs[:, int(np.argmin(np.abs(w - (1.0, -1.0)[which])))])
    return Bifurcation(("fold", "flip")[which], float(x[2]), float(x[0]), float(x[1]), vec)


class Branch(Result):
    """A branch of k/m orbits of the exact flat map at fixed alpha (dimensionless units).

    Arrays (one row per accepted point): ``gamma`` (n,), ``theta`` (n, m) impact phases
    (rad), ``V`` (n, m) velocities after them (``vrel w / g``), ``multipliers_re`` /
    ``multipliers_im`` (n, 2) eigenvalues of the monodromy matrix; ``bif_gamma`` (b,),
    ``bif_kind`` (b,) 0 fold (+1), 1 flip (-1), ``bif_theta``, ``bif_V`` (b,).
    Meta: ``k``, ``m``, ``alpha``, ``status``, ``reason`` (why the branch ends).
    """

    kind = "flat_orbit_branch"

    @property
    def bifurcations(self) -> list[tuple[str, float]]:
        """``[(kind, Gamma), ...]`` in the order met along the branch."""
        names = ("fold", "flip")
        return [
            (names[int(c)], float(g))
            for c, g in zip(self["bif_kind"], self["bif_gamma"], strict=True)
        ]

    def plot(self, ax=None):
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots()
        ax.plot(self["gamma"], self["theta"], "-", lw=0.8)
        ax.set(xlabel="Gamma", ylabel="impact phase (rad)")
        ax.set_title(f"{self.meta['k']}/{self.meta['m']} branch, alpha = {self.meta['alpha']}")
        return ax


def _jumped(old: Chain, new: Chain) -> int:
    """Index of a flight whose phase advance jumped by more than FLIGHT_JUMP, or -1."""
    d = np.abs(new.flight - old.flight)
    i = int(np.argmax(d))
    return i if d[i] > FLIGHT_JUMP else -1


def continue_branch(
    start: Point | tuple[float, float, float],
    k: int,
    m: int,
    alpha: float,
    *,
    gamma_min: float = 0.05,
    gamma_max: float = 20.0,
    ds: float = 0.02,
    ds_min: float = 1e-9,
    ds_max: float = 0.1,
    max_steps: int = 2000,
    direction: float = 1.0,
    stop_at_flip: bool = False,
    skip_first_test: bool = False,
) -> tuple[Branch, list[Point]]:
    """Pseudo-arclength continuation of a k/m orbit from ``start``.

    ``start`` is a ``Point`` or a guess ``(theta, V, Gamma)`` corrected at fixed Gamma.
    ``direction`` orients the first tangent (+1: increasing Gamma, or along the given
    tangent of a ``Point``).  Steps grow by 1.5 after an easy correction (<= 3 Newton
    iterations) up to ``ds_max`` and halve after a failure, a jump of a flight, or a
    failed replay; at ``ds_min`` the branch ends with the reason.  Folds and flips
    between accepted points are located (``_locate``).  ``skip_first_test`` ignores
    sign changes out of the start (a branch switched at a flip starts at a +1 multiplier).

    Returns ``(Branch, points)``: the branch and its corrected points.
    """
    if not isinstance(start, Point):
        start = _correct_at_gamma(*start, k, m, alpha)
    t0 = start.tangent if start.tangent[2] * direction >= 0 else -start.tangent
    p = Point(start.x, start.chain, t0)
    kind, why = _replay_ok(p.chain, p.x[2], alpha, k, m)
    if kind:
        raise OrbitLost(kind, why)
    points, bifs = [p], []
    status, reason = "max_steps", f"stopped after {max_steps} steps"
    tests = _tests(p.chain)
    for n_step in range(max_steps):
        try_ds = ds
        while True:
            try:
                x, ch, its = _correct(p.x + try_ds * p.tangent, p.tangent, k, m, alpha)
                jump = _jumped(p.chain, ch)
                kind, why = ("", "") if jump >= 0 else _replay_ok(ch, x[2], alpha, k, m)
                if jump < 0 and not kind:
                    break
                lost = (
                    OrbitLost("grazing", f"flight {jump} of the {k}/{m} orbit jumps from "
                              f"{p.chain.flight[jump]:.6g} to {ch.flight[jump]:.6g} rad near "
                              f"Gamma = {p.x[2]:.12g}: the continued flight would cut through "
                              "the plate (an earlier first contact)")
                    if jump >= 0 else OrbitLost(kind, why)
                )  # fmt: skip
            except OrbitLost as err:
                lost = err
            try_ds *= 0.5
            if try_ds < ds_min:
                status, reason = _diagnose_end(p, alpha, lost)
                return _branch(points, _bif_arrays(bifs), k, m, alpha, status, reason), points
        q = Point(x, ch, _tangent(ch, p.tangent))
        new_tests = _tests(ch)
        for which in (0, 1):
            if skip_first_test and n_step == 0:
                continue
            if tests[which] * new_tests[which] < 0.0:
                bifs.append(_locate(p, try_ds, which, k, m, alpha))
        points.append(q)
        p, tests = q, new_tests
        ds = min(ds_max, try_ds * (1.5 if its <= 3 else 1.0))
        if stop_at_flip and any(b.kind == "flip" for b in bifs):
            status, reason = "flip", f"period doubling at Gamma = {bifs[-1].gamma:.15g}"
            break
        if not gamma_min <= p.x[2] <= gamma_max:
            status, reason = "gamma_range", f"left [{gamma_min}, {gamma_max}] at {p.x[2]:.6g}"
            break
    return _branch(points, _bif_arrays(bifs), k, m, alpha, status, reason), points


def _diagnose_end(p: Point, alpha: float, lost: OrbitLost) -> tuple[str, str]:
    """Status and reason at a branch end: the corrector's, or ``"grazing"`` when a
    flight of the last orbit nearly touches the plate inside it (relative gap below
    ``GRAZE_REL`` of the flight's height scale ``x^2 / 8``)."""
    if lost.status != "newton":
        return lost.status, str(lost)
    gamma = p.x[2]
    for i, (th, v, x) in enumerate(zip(p.chain.theta, p.chain.V, p.chain.flight, strict=True)):
        s = np.linspace(0.0, x, 401)[1:-1]
        r = 2.0 * math.sin(th) * np.sin(0.5 * s) ** 2 - math.cos(th) * (np.sin(s) - s)
        gap = v * s - 0.5 * s * s - gamma * r
        j = int(np.argmin(gap))
        if 0 < j < len(s) - 1 and gap[j] < GRAZE_REL * x * x / 8.0:
            return "grazing", (
                f"flight {i} nearly touches the plate at phase {th + s[j]:.6g} (gap {gap[j]:.2g} "
                f"g/w^2) near Gamma = {gamma:.12g}: continued, it would cut through the plate"
            )
    return lost.status, f"{lost} (near Gamma = {gamma:.12g})"


def _bif_arrays(bifs: list[Bifurcation]) -> dict:
    return {
        "bif_gamma": np.array([b.gamma for b in bifs], dtype=float),
        "bif_kind": np.array([0 if b.kind == "fold" else 1 for b in bifs], dtype=np.int64),
        "bif_theta": np.array([b.theta for b in bifs], dtype=float),
        "bif_V": np.array([b.V for b in bifs], dtype=float),
    }


def _branch(points, bifs, k, m, alpha, status, reason) -> Branch:
    mult = np.array([_multipliers(p.chain) for p in points])
    arrays = {
        "gamma": np.array([p.x[2] for p in points]),
        "theta": np.array([p.chain.theta for p in points]),
        "V": np.array([p.chain.V for p in points]),
        "multipliers_re": mult.real,
        "multipliers_im": mult.imag,
        **bifs,
    }
    return Branch(arrays, make_meta(k=k, m=m, alpha=alpha, status=status, reason=reason))


# ---- period-doubling cascades --------------------------------------------------------------
def switch_at_flip(bif: Bifurcation, k: int, m: int, alpha: float, ds: float) -> Point:
    """First point of the 2k/2m branch born at the flip ``bif`` of a k/m branch.

    The doubled orbit leaves the flip point along the eigenvector of the multiplier
    -1 at fixed Gamma (a pitchfork of the twice-iterated map); the corrector is
    started there with that direction as tangent.  A solution that is still the
    k/m orbit (its point m impacts on equals its start) is refused and the step
    halved.
    """
    e = bif.eigvec / np.linalg.norm(bif.eigvec)
    t = np.array([e[0], e[1], 0.0])
    x0 = np.array([bif.theta, bif.V, bif.gamma])
    for _ in range(40):
        try:
            x, ch, _ = _correct(x0 + ds * t, t, 2 * k, 2 * m, alpha)
        except OrbitLost:
            ds *= 0.5
            continue
        # On the new branch the two halves differ by ~2 ds (|e0| + |e1|) >= 2 ds; the
        # k/m orbit traversed twice differs by rounding only.
        split = abs(math.remainder(ch.theta[m] - ch.theta[0], TWO_PI)) + abs(ch.V[m] - ch.V[0])
        if split > 0.5 * ds:
            return Point(x, ch, _tangent(ch, t))
        ds *= 0.5
    raise OrbitLost("newton", f"no {2 * k}/{2 * m} orbit found next to the flip at {bif.gamma!r}")


class CascadeTable(Result):
    """Period-doubling cascades of k/1 orbits at one alpha.

    Arrays: ``k`` (K,), ``gamma_doubling`` (K, N) Gamma of the n-th doubling (period
    2^(n-1) -> 2^n impacts; NaN where not reached), ``ratio`` (K, N) Feigenbaum
    estimates ``(G_n - G_(n-1)) / (G_(n+1) - G_n)`` at column n (NaN where undefined).
    Meta: ``alpha``, ``levels``, ``status`` and ``reason`` per k (why the cascade stops).
    """

    kind = "flat_doubling_cascades"

    def rows(self) -> list[dict]:
        """One dict per k: doublings, ratios (finite values only), status, reason."""
        out = []
        for i, k in enumerate(self["k"]):
            g, r = self["gamma_doubling"][i], self["ratio"][i]
            out.append(
                {
                    "k": int(k),
                    "gamma_doublings": [float(v) for v in g[np.isfinite(g)]],
                    "feigenbaum_ratios": [float(v) for v in r[np.isfinite(r)]],
                    "status": self.meta["status"][i],
                    "reason": self.meta["reason"][i],
                }
            )
        return out


def feigenbaum_ratios(gammas) -> np.ndarray:
    """``(G_n - G_(n-1)) / (G_(n+1) - G_n)`` for n = 1 .. len-2 (array of len - 2)."""
    d = np.diff(np.asarray(gammas, dtype=float))
    return d[:-1] / d[1:]


def k1_start(k: int, alpha: float) -> Point:
    """A corrected point of the stable k/1 branch halfway up its tongue (closed-form guess)."""
    gamma = 0.5 * (tongue_gamma_lo(k, alpha) + tongue_gamma_hi(k, alpha))
    theta = TWO_PI - math.acos(k1_cos_phase(k, gamma, alpha))
    return _correct_at_gamma(theta, 2 * alpha * math.pi * k / (1 + alpha), gamma, k, 1, alpha)


def cascade(k: int, alpha: float, levels: int) -> tuple[list[float], str, str, list[Branch]]:
    """Gammas of the first ``levels`` doublings of the k/1 orbit (1 -> 2 -> 4 ...).

    Each level is continued from the previous flip (``switch_at_flip``) up to its
    own flip; steps scale with the previous level's Gamma interval.  Returns
    ``(gammas, status, reason, branches)``; ``status`` is ``"done"`` or why the
    cascade stopped (a branch ended otherwise than at a flip).
    """
    start, m, span = k1_start(k, alpha), 1, 0.5
    gammas, branches = [], []
    for _ in range(levels):
        # past the previous doubling the next one is expected ~span / 4.67 on
        gamma_max = gammas[-1] + CASCADE_REACH * span if gammas else 20.0
        br, _ = continue_branch(
            start, k * m, m, alpha, ds=0.02 * span, ds_max=0.1 * span, ds_min=1e-12 * span,
            stop_at_flip=True, skip_first_test=m > 1, max_steps=CASCADE_MAX_STEPS,
            gamma_max=gamma_max,
        )  # fmt: skip
        branches.append(br)
        flips = [g for kind, g in br.bifurcations if kind == "flip"]
        if br.meta["status"] != "flip":
            why = br.meta["reason"]
            if br.meta["status"] == "gamma_range":
                why = (
                    f"the {k * m}/{m} branch passed Gamma = {gamma_max:.15g} ({CASCADE_REACH:g} "
                    f"times the previous interval) without a multiplier -1: level not resolved"
                )
            return gammas, br.meta["status"], why, branches
        gammas.append(flips[-1])
        i = int(np.flatnonzero(br["bif_kind"] == 1)[-1])
        x = np.array([br["bif_theta"][i], br["bif_V"][i], flips[-1]])
        bif = _bifurcation(1, x, orbit_chain(*x, k * m, m, alpha))
        span = gammas[-1] - gammas[-2] if len(gammas) > 1 else span
        try:
            start = switch_at_flip(bif, k * m, m, alpha, 0.05 * span)
        except OrbitLost as err:
            return gammas, err.status, str(err), branches
        m *= 2
    return gammas, "done", f"{levels} doublings", branches


# ---- k/m resonances ------------------------------------------------------------------------
def km_orbit_guesses(k: int, m: int, alpha: float, gammas, n_phase: int = 16) -> list[Point]:
    """Distinct k/m orbits of least period m found by Newton from a grid of guesses.

    At each Gamma of ``gammas``, Newton at fixed Gamma starts from ``n_phase`` impact
    phases and three velocities around ``V = 2 alpha pi k / ((1 + alpha) m)`` (the
    k/1 value for a mean flight of ``2 pi k / m``).  Orbits that the simulator does
    not follow (a stick) or of a shorter period are dropped; one point per orbit
    and Gamma (its points are compared as a set).
    """
    if gcd(k, m) != 1:
        raise ValueError(
            f"k/m = {k}/{m} is not in lowest terms; use {k // gcd(k, m)}/{m // gcd(k, m)}"
        )
    found: list[Point] = []
    v0 = 2 * alpha * math.pi * k / ((1 + alpha) * m)
    for gamma in gammas:
        seen: list[np.ndarray] = []
        for theta in np.linspace(0.0, TWO_PI, n_phase, endpoint=False):
            for v in (0.5 * v0, v0, 1.5 * v0):
                try:
                    p = _correct_at_gamma(theta, v, gamma, k, m, alpha)
                except OrbitLost:
                    continue
                if _least_period(p.chain) != m or _replay_ok(p.chain, gamma, alpha, k, m)[0]:
                    continue
                key = np.sort(p.chain.theta)
                if any(np.allclose(key, s, atol=1e-7) for s in seen):
                    continue
                seen.append(key)
                found.append(p)
    return found


def _least_period(ch: Chain) -> int:
    """Smallest d dividing m such that the orbit repeats after d impacts."""
    m = len(ch.theta)
    for d in range(1, m + 1):
        if (
            m % d == 0
            and np.allclose(np.roll(ch.theta, d), ch.theta, atol=1e-9)
            and np.allclose(np.roll(ch.V, d), ch.V, rtol=1e-9)
        ):
            return d
    return m


def km_regions(
    k: int, m: int, alpha: float, gammas, n_phase: int = 16, gamma_max: float = 20.0
) -> list[Branch]:
    """Branches of k/m orbits through the orbits of ``km_orbit_guesses`` (both directions).

    A branch already found from another starting orbit is skipped (an orbit whose
    Gamma lies within a previous branch's range and whose phases match it).
    Each returned Branch records its folds and flips, and why it ends on either side.
    """
    branches: list[Branch] = []
    for p in km_orbit_guesses(k, m, alpha, gammas, n_phase):
        if any(_on_branch(p, b) for b in branches):
            continue
        halves = []
        for direction in (-1.0, 1.0):
            try:
                br, _ = continue_branch(p, k, m, alpha, direction=direction, gamma_max=gamma_max)
            except OrbitLost:
                continue
            halves.append(br)
        if halves:
            branches.append(_join(halves))
    return branches


def _on_branch(p: Point, br: Branch) -> bool:
    """Whether orbit ``p`` is (close to) a point of ``br`` at nearly the same Gamma."""
    near = np.flatnonzero(np.abs(br["gamma"] - p.x[2]) < 0.05)
    key = np.sort(p.chain.theta)
    return any(np.max(np.abs(np.sort(br["theta"][i]) - key)) < 0.3 for i in near)


def _join(halves: list[Branch]) -> Branch:
    """One Branch from the backward and forward halves (first half reversed)."""
    first, rest = halves[0], halves[1:]
    arrays = {}
    for name in first.arrays:
        parts = [first[name][::-1]] + [h[name] for h in rest]
        arrays[name] = np.concatenate(parts)
    ends = [f"{h.meta['status']}: {h.meta['reason']}" for h in halves]
    meta = dict(first.meta, status=halves[-1].meta["status"], reason=" | ".join(ends))
    return Branch(arrays, meta)


def doubling_cascade(alpha: float = 0.5, kmax: int = 3, levels: int = 8) -> CascadeTable:
    """Period-doubling cascades of the k/1 orbits, k = 1..kmax, ``levels`` doublings each.

    Column n of ``gamma_doubling`` is the n-th doubling (period 2^n impacts born);
    ``ratio`` holds the Feigenbaum estimates, NaN where fewer doublings were reached.
    """
    import time

    start = time.perf_counter()
    if not 0.0 < float(alpha) < 1.0:
        raise ValueError(f"alpha must be in (0, 1) for a dissipative cascade, got {alpha}")
    if levels < 1 or kmax < 1:
        raise ValueError(f"kmax and levels must be >= 1, got kmax={kmax}, levels={levels}")
    table = np.full((kmax, levels), np.nan)
    ratios = np.full((kmax, levels), np.nan)
    status, reason = [], []
    for i in range(kmax):
        gammas, st, why, _ = cascade(i + 1, alpha, levels)
        table[i, : len(gammas)] = gammas
        if len(gammas) > 2:
            ratios[i, 1 : len(gammas) - 1] = feigenbaum_ratios(gammas)
        status.append(st)
        reason.append(why)
    meta = make_meta(
        wall_s=time.perf_counter() - start, alpha=float(alpha), levels=levels,
        status=status, reason=reason,
    )  # fmt: skip
    return CascadeTable(
        {"k": np.arange(1, kmax + 1), "gamma_doubling": table, "ratio": ratios}, meta
    )


def bifurcation_diagram(gammas, alpha: float, transient: int, record: int) -> np.ndarray:
    """Impact phases (rad) of the flat ball by direct iteration of the exact map, against Gamma.

    Gamma is swept up through ``gammas`` (sorted), each run starting from the last state
    of the previous one (the first from the stable 1/1 orbit, docs/model.md §1); after
    ``transient`` events, the phases of the next ``record`` events are kept (NaN for
    events that are not impacts, and a row of NaN where the run fails).

    Returns
    -------
    array, shape (len(gammas), record)
    """
    gammas = np.asarray(gammas, dtype=float)
    g0 = min(max(gammas[0], tongue_gamma_lo(1, alpha)), tongue_gamma_hi(1, alpha))
    theta = TWO_PI - np.arccos(k1_cos_phase(1, g0, alpha))
    state = (0.0, float(theta), 2 * alpha * np.pi / (1 + alpha), IMPACT)
    phases = np.full((len(gammas), record), np.nan)
    n = transient + record
    for i, gamma in enumerate(gammas):
        out = [np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n, dtype=np.int64)]
        kp = unit_kernel(float(gamma), alpha)
        _, done, status = flat_run(FlatState(*state), kp, n, FlatArrays(*out))
        if status != OK or done < n:
            continue
        kinds = out[3][transient:]
        phases[i] = np.where(kinds == IMPACT, out[1][transient:], np.nan)
        state = (0.0, float(out[1][-1]), float(out[2][-1]), int(out[3][-1]))
    return phases
