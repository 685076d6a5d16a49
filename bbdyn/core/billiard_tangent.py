"""Tangent dynamics of the billiard through every event (docs/lyapunov.md), numba kernels.

The reference trajectory is the exact event kernel's (``core.billiard``: the
event is ``billiard_flight``, ``advance_phase``, ``collide``, exactly as in
``billiard_event``; ``tests/test_billiard_tangent.py`` checks bitwise equality).
Along it, the Jacobian of the *event map* is built event by event.

Coordinates.  An event state (just after an IMPACT, a STICK or a RELEASE; the
particle is on the floor) has the *section coordinates*

    q = (theta, x, vx, vyrel)      (rad, mm, mm/s, mm/s),

``theta = w t`` lifted (not reduced mod 2 pi), ``x = tile d + xi`` the lifted
horizontal position, ``vyrel = vy - u(t)``.  The event map ``q_n -> q_{n+1}``
has the 4x4 Jacobian ``J_n``, built from the flow's tangent ``dz`` at a *fixed
time*, ``z = (x, y, vx, vy)`` (``vy`` absolute):

    J_n = C(q_{n+1}) S_k ... S_1 Phi(tau) E(q_n).

Floor gap.  ``h(z, t) = y - y_p(t) - b(xi)``, ``grad h = (-b', 1, 0, 0)`` with
``b' = -xi / S``, ``S = sqrt(R^2 - xi^2)``, ``h_t = -u(t)``; its rate along the
motion is ``hdot = grad h . f + h_t = vyrel - b' vx = R V_n / S`` (``V_n`` the
normal relative velocity).  ``u = -A w cos theta``, ``a = A w^2 sin theta``.

E (event -> fixed time).  A start moved by ``dq`` happens at ``t + dt``
(``dt = dtheta / w``) at ``(x + dx, y_p(t + dt) + b(xi + dx))``; carried back to
``t`` along the flight that leaves it (``f+ = (vx, vy, 0, -g)``):

    dx_z = dx - vx dt,   dy = b' dx - vyrel dt,   dvx_z = dvx,   dvy = dvyrel + (a + g) dt.

C (fixed time -> event), its inverse on the floor: the event of the perturbed
trajectory is where it meets the floor, ``dt = -(dy - b' dx) / hdot+`` (needs the
departure to be transversal, ``V_n+ > 0``, i.e. alpha > 0), then

    dtheta = w dt,   dx = dx_z + vx dt,   dvx = dvx_z,   dvyrel = dvy - (a + g) dt.

Phi (flight, duration tau).  Gravity is uniform: ``dx += tau dvx``,
``dy += tau dvy``; wedge crossings during the flight are not events of the flow.

S (saltation matrix of an impact on the moving arc).  The impact map at the
contact ``xi`` is ``v+ = U + B(xi) (v- - U)``, ``U = (0, u(t))``,

    B = -alpha n n^T + beta t t^T,    n = (xi, S) / R,   t = (S, -xi) / R,

positions unchanged.  The impact time depends on the state through the gap
(``dt_c = -grad h . dz- / hdot-``: the floor's height *and* its motion), the
reflection on the state through the normal at the impact point
(``dn/dxi = t / S``, ``dt/dxi = -n / S``) and on the time through ``U``.
Differentiating ``z+(t_c + dt_c)`` and carrying it back to the reference time,

    S = Dg + (f+ - Dg f- - g_t) grad h^T / hdot-,

    Dg = [[1, 0, 0, 0], [0, 1, 0, 0], [p, 0, B]],   g_t = (0, 0, (I - B) (0, a)),
    p = (dB/dxi) w = -(alpha + beta) (t V_n + n V_t) / S,   f+- = (vx+-, vy+-, 0, -g),

``w = v- - U = (V_n, V_t)`` in the (n, t) frame.  ``det S = det B hdot+ / hdot-
= -alpha beta hdot+ / hdot-``, so along a trajectory ``sum log |det J_n|`` is
``log (alpha beta)`` per reflection plus the telescoped ``log hdot+_0 / hdot+_N``
(tested).  A wedge contact (the wedge rule of ``collide``) is a chain of
saltation matrices at the same point and time, alternately with the normal of
the arc the particle came over and of its neighbour (``S_k ... S_1``; the
reflections are those ``wedge_reflect`` makes); it is the limit of an impact
close to the wedge followed at once by one on the neighbour.

Sticking: the tangent space collapses onto the floor.  A chattering sequence
summed in closed form (``chatter_sum``) ends at the stick point

    xi_s = xi cos(ds / R) + S sin(ds / R),    theta_s = theta + w tau_inf,

with ``tau_inf, ds`` functions of ``(theta, xi, V_n, V_t)`` just after the last
impact (``chatter_sum``): ``g_eff = g + a``, ``g_0 = g_eff S / R``,
``eps = V_t^2 / (g_eff S)``, ``tau_0 = 2 V_n / g_0``, ``tau_inf = tau_0 F(eps; alpha, beta^2)``,
``g_t = g_eff xi / R``, ``ds = V_t tau_0 F(eps; alpha beta, beta^2) + g_t tau_0^2 c_2`` with
``c_2 = alpha beta / ((1 - alpha^2)(1 - alpha beta)) + 1 / (2 (1 - alpha^2))``, and ``F``,
``dF/deps`` from ``shrinking_series``.
Its Jacobian ``K`` has only the rows ``theta_s`` and ``x_s``: the velocity
components ``dvx, dvyrel`` vanish (the particle rests on the floor).  A stick
at a wedge (a drift clamped there, a wedge collapse, ``V_n = 0``) pins the
position too: ``J = 0``, a *collapse* of the whole tangent space.

Release.  A stick ends at ``theta_r = pi + asin(1/Gamma)`` (``stick_release``),
which does not depend on the state: the release's Jacobian is
``diag(0, 1, 0, 0)`` (only the stick point ``x_s`` is carried; the particle
leaves with the floor's velocity).  A stick inside the release window ends at
once, at the stick's own time: then ``dtheta_r = dtheta_s``, ``diag(1, 1, 0, 0)``.
So at every stick the tangent space collapses onto the one direction along the
floor; the largest exponent stays finite unless the particle sticks at a wedge.
The flight after a release is singular too: the particle leaves at zero relative
velocity where the floor's acceleration is ``-g``, so the phase column of ``E``
vanishes (``det E = hdot / w = 0``).

The frame (``billiard_tangent_run``).  ``m`` tangent vectors (1: the largest exponent,
4: the whole spectrum) are pushed through the same ``J`` and re-orthonormalised by
Gram-Schmidt (``J Q = Q' R``).  Over the *carried* events (impact to impact, regular
``J``) the sums of ``log R_ii`` are kept with the closed-form ``log |det J|``
(``event_log_det``).  Through a stick, its release and the flight after it the first
vector alone goes on (its growth is the largest exponent's) and the others restart as
a basis of its complement: the three exponents after it are ``-inf``.
"""

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from bbdyn.core.billiard import (
    billiard_flight,
    collide,
    shrinking_series,
    snap_to_wedge,
    wedge_reflect,
)
from bbdyn.core.floor import arc_root, bounce
from bbdyn.core.plate import TWO_PI, advance_phase, sin_cos, stick_release
from bbdyn.core.status import IMPACT, NON_FINITE, OK, RELEASE, STICK, STUCK_FOREVER
from bbdyn.core.tolerances import FMA


@njit(cache=True, fastmath=FMA, inline="always")
def set_identity(M):
    """Set the 4x4 array ``M`` to the identity (in place)."""
    for i in range(4):
        for j in range(4):
            M[i, j] = 1.0 if i == j else 0.0


@njit(cache=True, fastmath=FMA, inline="always")
def left_multiply(L, M, T):
    """``M <- L M`` for 4x4 arrays, with ``T`` a 4x4 scratch array."""
    for i in range(4):
        for j in range(4):
            acc = 0.0
            for k in range(4):
                acc += L[i, k] * M[k, j]
            T[i, j] = acc
    for i in range(4):
        for j in range(4):
            M[i, j] = T[i, j]


@njit(cache=True, fastmath=FMA, inline="always")
def section_to_flow(phase, xi, vx, vyrel, kp, M):
    """Write E (section coordinates -> fixed-time flow tangent, module docstring) into ``M``."""
    w = kp.w
    S = arc_root(xi, kp)
    slope = -xi / S
    acc = kp.A * w * w * math.sin(phase) + kp.g
    for i in range(4):
        for j in range(4):
            M[i, j] = 0.0
    M[0, 0] = -vx / w
    M[0, 1] = 1.0
    M[1, 0] = -vyrel / w
    M[1, 1] = slope
    M[2, 2] = 1.0
    M[3, 0] = acc / w
    M[3, 3] = 1.0


@njit(cache=True, fastmath=FMA, inline="always")
def flow_to_section(phase, xi, vx, vyrel, kp, M):
    """Write C (fixed-time flow tangent just after an event -> section coordinates) into ``M``."""
    w = kp.w
    S = arc_root(xi, kp)
    slope = -xi / S
    hdot = vyrel - slope * vx  # R V_n / S > 0 after an impact
    acc = kp.A * w * w * math.sin(phase) + kp.g
    set_identity(M)
    # dt = -(dy - slope dx) / hdot
    M[0, 0] = w * slope / hdot
    M[0, 1] = -w / hdot
    M[1, 0] = 1.0 + vx * slope / hdot
    M[1, 1] = -vx / hdot
    M[3, 0] = -acc * slope / hdot
    M[3, 1] = acc / hdot


@njit(cache=True, fastmath=FMA, inline="always")
def flight_flow(tau, M):
    """``M <- Phi(tau) M``: a free flight of ``tau`` s (rows x += tau vx, y += tau vy)."""
    for j in range(4):
        M[0, j] += tau * M[2, j]
        M[1, j] += tau * M[3, j]


@njit(cache=True, fastmath=FMA, inline="always")
def saltation(phase, xi, vx, vyrel, kp, M):
    """Write the saltation matrix of an impact at ``xi`` into ``M`` (module docstring).

    ``vx, vyrel`` are the velocity relative to the floor just before the impact
    (mm/s) and ``phase`` its time (rad).  Returns the relative velocity after it
    (``floor.bounce``) and ``V_n, V_t`` after it, as ``(vx+, vyrel+, vn+, vt+)``.
    """
    R, alpha, beta, g, w = kp.R, kp.alpha, kp.beta, kp.g, kp.w
    S = arc_root(xi, kp)
    nx, ny = xi / R, S / R
    tx, ty = S / R, -xi / R
    b00 = -alpha * nx * nx + beta * tx * tx
    b01 = -alpha * nx * ny + beta * tx * ty
    b11 = -alpha * ny * ny + beta * ty * ty
    wn = nx * vx + ny * vyrel
    wt = tx * vx + ty * vyrel
    c = -(alpha + beta) / S
    p0 = c * (tx * wn + nx * wt)
    p1 = c * (ty * wn + ny * wt)
    a = kp.A * w * w * math.sin(phase)
    vxp, vyp, vnp, vtp = bounce(xi, vx, vyrel, kp)
    slope = -xi / S
    hdot_minus = vyrel - slope * vx
    # a_vec = f+ - Dg f- - g_t
    a0 = vxp - vx
    a1 = vyp - vyrel  # (vyp + u) - (vyrel + u)
    a2 = -(p0 * vx - b01 * g) + b01 * a
    a3 = -g - (p1 * vx - b11 * g) - (1.0 - b11) * a
    set_identity(M)
    M[2, 0] = p0
    M[3, 0] = p1
    M[2, 2] = b00
    M[2, 3] = b01
    M[3, 2] = b01
    M[3, 3] = b11
    grad0 = -slope / hdot_minus
    grad1 = 1.0 / hdot_minus
    av = (a0, a1, a2, a3)
    for i in range(4):
        M[i, 0] += av[i] * grad0
        M[i, 1] += av[i] * grad1
    return vxp, vyp, vnp, vtp


@njit(cache=True, fastmath=FMA, inline="always")
def chatter_stick_rows(phase, xi, vx, vyrel, kp, M):
    """Write K (section coordinates just after the last impact -> stick point) into ``M``.

    Rows ``theta_s`` and ``x_s`` of the closed-form chattering sum (module docstring);
    the velocity rows are zero.  ``vx, vyrel`` are the relative velocity after the impact.
    The caller checks that the stick point is not clamped at a wedge (a collapse).
    """
    R, alpha, beta, w = kp.R, kp.alpha, kp.beta, kp.w
    for i in range(4):
        for j in range(4):
            M[i, j] = 0.0
    S = arc_root(xi, kp)
    vn = (vx * xi + vyrel * S) / R
    vt = (vx * S - vyrel * xi) / R
    aw2 = kp.A * w * w
    g_eff = kp.g + aw2 * math.sin(phase)
    g0 = g_eff * S / R
    eps = vt * vt / (g_eff * S)
    tau0 = 2.0 * vn / g0
    F, dF, _ = shrinking_series(eps, alpha, beta * beta)
    H, dH, _ = shrinking_series(eps, alpha * beta, beta * beta)
    g_t = g_eff * xi / R
    ab = alpha * beta
    one_a2 = 1.0 - alpha * alpha
    c2 = ab / (one_a2 * (1.0 - ab)) + 0.5 / one_a2
    ds = vt * tau0 * H + g_t * tau0 * tau0 * c2
    cr, sr = math.cos(ds / R), math.sin(ds / R)
    for j in range(4):
        # one input direction of (theta, x, vx, vyrel): forward-mode derivatives
        d_th = 1.0 if j == 0 else 0.0
        d_xi = 1.0 if j == 1 else 0.0
        d_vx = 1.0 if j == 2 else 0.0
        d_vy = 1.0 if j == 3 else 0.0
        d_S = -xi / S * d_xi
        d_vn = (d_vx * xi + vx * d_xi + d_vy * S + vyrel * d_S) / R
        d_vt = (d_vx * S + vx * d_S - d_vy * xi - vyrel * d_xi) / R
        d_geff = aw2 * math.cos(phase) * d_th
        d_g0 = (d_geff * S + g_eff * d_S) / R
        d_eps = (2.0 * vt * d_vt - eps * (d_geff * S + g_eff * d_S)) / (g_eff * S)
        d_tau0 = 2.0 * d_vn / g0 - tau0 * d_g0 / g0
        d_gt = (d_geff * xi + g_eff * d_xi) / R
        d_ds = (
            H * (d_vt * tau0 + vt * d_tau0)
            + vt * tau0 * dH * d_eps
            + c2 * (d_gt * tau0 * tau0 + 2.0 * g_t * tau0 * d_tau0)
        )
        M[0, j] = d_th + w * (d_tau0 * F + tau0 * dF * d_eps)
        M[1, j] = d_xi * cr + d_S * sr + (S * cr - xi * sr) * d_ds / R



@njit(cache=True, fastmath=FMA)
def billiard_tangent_step(periods, phase, tile, xi, vx, vyrel, kind, kp, mats):
    """``billiard_tangent_event`` that also returns the number of reflections of the event.

    Returns ``(periods, phase, tile, xi, vx, vyrel, kind, status, reflections)``:
    ``reflections`` is the number of saltation matrices in ``J`` (1 for an impact on an
    arc, more for a wedge chain, 0 for a release), which ``event_log_det`` needs.
    """
    J, W, T = mats
    if kind == STICK:
        periods_r, phase_r, status = stick_release(periods, phase, kp)
        for i in range(4):
            for j in range(4):
                J[i, j] = 0.0
        if status != OK:
            return periods, phase, tile, xi, 0.0, 0.0, STICK, status, 0
        J[1, 1] = 1.0
        if periods_r == periods and phase_r == phase:  # released at once: its time is the stick's
            J[0, 0] = 1.0
        return periods_r, phase_r, tile, xi, 0.0, 0.0, RELEASE, OK, 0

    tau, k, xi_c, vyrel_minus, _, status = billiard_flight(phase, xi, vx, vyrel, kp)
    if status != OK:
        return periods, phase, tile, xi, vx, vyrel, kind, status, 0
    section_to_flow(phase, xi, vx, vyrel, kp, J)
    flight_flow(tau, J)
    periods_c, phase_c = advance_phase(periods, phase, kp.w * tau)
    sn_c, cs_c = sin_cos(phase_c)
    nxt, status, _ = collide(periods_c, phase_c, sn_c, cs_c, tile + k, xi_c, vx, vyrel_minus, kp)
    if status != OK:
        return nxt.periods, nxt.phase, nxt.tile, nxt.xi, nxt.vx, nxt.vyrel, nxt.kind, status, 0
    # the chain of reflections of collide: the first on the arc under the particle ...
    tile_r = tile + k
    xi_r = snap_to_wedge(xi_c, kp)
    vx_r, vy_r = vx, vyrel_minus
    vx_r, vy_r, vn_r, vt_r = saltation(phase_c, xi_r, vx_r, vy_r, kp, W)
    left_multiply(W, J, T)
    reflections = 1
    # ... then one on the neighbour each time wedge_reflect would reflect again
    for _ in range(64):
        t2, x2, vx2, vy2, _, _, _ = wedge_reflect(tile_r, xi_r, vx_r, vy_r, vn_r, vt_r, kp)
        if t2 == tile_r and x2 == xi_r and vx2 == vx_r and vy2 == vy_r:
            break
        tile_r = tile_r + (1.0 if xi_r > 0.0 else -1.0)
        xi_r = -xi_r
        vx_r, vy_r, vn_r, vt_r = saltation(phase_c, xi_r, vx_r, vy_r, kp, W)
        left_multiply(W, J, T)
        reflections += 1
    out = (nxt.periods, nxt.phase, nxt.tile, nxt.xi, nxt.vx, nxt.vyrel, nxt.kind)
    if nxt.kind == IMPACT:
        flow_to_section(phase_c, xi_r, vx_r, vy_r, kp, W)
        left_multiply(W, J, T)
        return out + (OK, reflections)
    # STICK: a chattering sum ending on the arc keeps the stick point; anything else collapses
    half = 0.5 * kp.d
    if abs(nxt.xi) < half and vn_r > 0.0:
        flow_to_section(phase_c, xi_r, vx_r, vy_r, kp, W)
        left_multiply(W, J, T)
        chatter_stick_rows(phase_c, xi_r, vx_r, vy_r, kp, W)
        left_multiply(W, J, T)
        return out + (OK, reflections)
    for i in range(4):
        for j in range(4):
            J[i, j] = 0.0
    return out + (OK, reflections)


@njit(cache=True, fastmath=FMA)
def billiard_tangent_event(periods, phase, tile, xi, vx, vyrel, kind, kp, mats):
    """Advance the billiard by one event and write the event map's Jacobian into ``J``.

    Parameters
    ----------
    periods, phase, tile, xi, vx, vyrel, kind
        Current event state (``core.billiard.billiard_event``).
    kp : KernelParams
    mats : (J, W, T), ndarrays (4, 4)
        ``J`` out: ``d q_{n+1} / d q_n`` in section coordinates ``(theta, x, vx, vyrel)``
        (module docstring); all zero for a collapse (a stick at a wedge).  ``W, T``:
        scratch.

    Returns
    -------
    (periods, phase, tile, xi, vx, vyrel, kind, status)
        The next event, bitwise that of ``billiard_event``.
    """
    out = billiard_tangent_step(periods, phase, tile, xi, vx, vyrel, kind, kp, mats)
    return out[0], out[1], out[2], out[3], out[4], out[5], out[6], out[7]


@njit(cache=True, fastmath=FMA, inline="always")
def gap_rate(xi, vx, vyrel, kp):
    """``hdot = vyrel + xi vx / S = R V_n / S`` just after an impact (mm/s, > 0)."""
    return vyrel + xi * vx / arc_root(xi, kp)


@njit(cache=True, fastmath=FMA, inline="always")
def event_log_det(xi0, vx0, vyrel0, xi1, vx1, vyrel1, reflections, kp):
    """``log |det J|`` of an impact-to-impact event in closed form (module docstring).

    ``det E = hdot+_0 / w``, ``det C = w / hdot+_1`` and ``|det S| = alpha^2 beta`` per
    reflection (``det B = -alpha beta`` times ``|hdot+ / hdot-| = alpha``), so
    ``log |det J| = reflections log(alpha^2 beta) + log hdot+_0 - log hdot+_1``: from the
    two event states and the count alone, not from the matrix.
    """
    restitution = math.log(kp.alpha * kp.alpha * kp.beta)
    return (
        reflections * restitution
        + math.log(gap_rate(xi0, vx0, vyrel0, kp))
        - math.log(gap_rate(xi1, vx1, vyrel1, kp))
    )


class SpectrumWindows(NamedTuple):
    """Output arrays of ``billiard_tangent_run`` for the whole frame, one row per window."""

    log: np.ndarray  # (n_w, m): sums of log R_ii over the carried (impact-to-impact) events
    log_det: np.ndarray  # (n_w,): closed-form log |det J| summed over the same events (m = 4)
    carried: np.ndarray  # int64 (n_w,): impact-to-impact events carried by the whole frame
    carried_time: np.ndarray  # (n_w,): driving periods of the carried events
    sticks: np.ndarray  # int64 (n_w,): STICK events


@njit(cache=True, fastmath=FMA, inline="always", error_model="numpy")
def frame_multiply(J, A, T):
    """``A <- J A`` for the (4, m) frame ``A``, ``T`` a (4, m) scratch array."""
    for c in range(A.shape[1]):
        for i in range(4):
            acc = 0.0
            for k in range(4):
                acc += J[i, k] * A[k, c]
            T[i, c] = acc
    for c in range(A.shape[1]):
        for i in range(4):
            A[i, c] = T[i, c]


@njit(cache=True, fastmath=FMA, inline="always", error_model="numpy")
def orthonormalise(A, logs):
    """Gram-Schmidt (modified, twice) of the columns of ``A`` in place:
    ``A = Q R``; writes ``log R_ii`` into ``logs[i]`` (``-inf`` for a vanishing column)."""
    for c in range(A.shape[1]):
        for _ in range(2 if c > 0 else 0):  # twice is enough (the projections are not in R)
            for p in range(c):
                dot = 0.0
                for k in range(4):
                    dot += A[k, p] * A[k, c]
                for k in range(4):
                    A[k, c] -= dot * A[k, p]
        r = math.sqrt(A[0, c] * A[0, c] + A[1, c] * A[1, c] + A[2, c] * A[2, c] + A[3, c] * A[3, c])
        logs[c] = math.log(r)
        for k in range(4):
            A[k, c] = A[k, c] / r


@njit(cache=True, fastmath=FMA, inline="always")
def complete_frame(A):
    """Columns ``1, ...`` of ``A`` <- an orthonormal basis of the complement of column 0
    (a unit vector): the columns of the Householder reflection that maps e_0 to it."""
    s = 1.0 if A[0, 0] >= 0.0 else -1.0
    v0, v1, v2, v3 = A[0, 0] + s, A[1, 0], A[2, 0], A[3, 0]
    vv = v0 * v0 + v1 * v1 + v2 * v2 + v3 * v3
    v = (v0, v1, v2, v3)
    for c in range(1, A.shape[1]):
        for i in range(4):
            A[i, c] = (1.0 if i == c else 0.0) - 2.0 * v[i] * v[c] / vv


@njit(cache=True, fastmath=FMA, error_model="numpy")
def billiard_tangent_run(state, kp, t_ends, frame, qr_every, out, spec):
    """Advance one particle through events with a tangent frame, window by window (QR method).

    Parameters
    ----------
    state : tuple
        Current event state ``(periods, phase, tile, xi, vx, vyrel, kind)``.
    kp : KernelParams
    t_ends : ndarray (n_windows,)
        Ends of the windows in driving periods, increasing (as ``core.tangent.flat_tangent_run``).
    frame : ndarray (4, m)
        Orthonormal tangent vectors in section coordinates (in/out): ``m = 1`` the largest
        exponent, ``m = 4`` the whole spectrum.  ``frame @ R`` is ``J frame`` after each QR.
    qr_every : int
        Impact-to-impact events between two QR steps (>= 1; the R factors multiply, so the
        exponents do not depend on it beyond rounding).  A stick, a release or a window's
        end takes the QR step at once.
    out : TangentWindows
        Column 0 through every event (the largest exponent), per window (added to):
        ``log``, the sum of ``log R_00``; ``collisions`` (IMPACT and STICK events) and
        ``collapses`` (sticks at a wedge, where ``J = 0``; column 0 restarts along the floor,
        ``(0, 1, 0, 0)``); ``time`` (driving periods) of its last event (overwritten).
    spec : SpectrumWindows
        The whole frame over the *carried* events, those from an impact to an impact, whose
        Jacobian is regular (added to).  A stick, and the release and flight after it, have
        singular Jacobians (the velocity rows vanish, then all but the position; docs/
        lyapunov.md): column 0 alone goes through them, and the columns after it restart
        as a basis of its complement.  ``log_det`` only for ``m = 4``.

    Returns
    -------
    (state, status)
        The last event; ``status`` ``OK``, ``STUCK_FOREVER`` (Gamma <= 1; the window it
        sticks in ends at its end: it rests there), ``NON_FINITE`` (a non-finite tangent
        vector: a grazing contact, whose event map has no derivative) or a failure of
        the event kernel.
    """
    periods, phase, tile, xi, vx, vyrel, kind = state
    out_log, out_collisions, out_collapses, out_time = out
    m = frame.shape[1]
    J = np.empty((4, 4))
    W = np.empty((4, 4))
    T = np.empty((4, 4))
    A = frame.copy()
    scratch = np.empty((4, m))
    logs = np.empty(m)
    n_w = t_ends.shape[0]
    j = 0
    t = periods + phase / TWO_PI
    while j < n_w and t > t_ends[j]:
        j += 1
    status = OK
    pending, pending_window, pending_det, pending_time = 0, j, 0.0, 0.0
    while j < n_w:
        before = kind
        xi0, vx0, vy0, t0 = xi, vx, vyrel, t
        periods, phase, tile, xi, vx, vyrel, kind, status, reflections = billiard_tangent_step(
            periods, phase, tile, xi, vx, vyrel, kind, kp, (J, W, T)
        )
        if status == STUCK_FOREVER:
            out_time[j] = max(t, t_ends[j])  # it rests on the floor to the window's end
            break
        if status != OK:
            break
        t = periods + phase / TWO_PI
        while j < n_w - 1 and t > t_ends[j]:
            j += 1
        carried = before == IMPACT and kind == IMPACT
        if pending > 0 and (not carried or j != pending_window):
            status = _qr_step(A, logs, pending_window, out_log, spec, pending, pending_det,
                              pending_time)  # fmt: skip
            pending, pending_det, pending_time = 0, 0.0, 0.0
            if status != OK:
                break
        frame_multiply(J, A, scratch)
        if carried:
            pending += 1
            pending_window = j
            pending_time += t - t0
            if m == 4:
                pending_det += event_log_det(xi0, vx0, vy0, xi, vx, vyrel, reflections, kp)
            if pending == qr_every:
                status = _qr_step(A, logs, j, out_log, spec, pending, pending_det, pending_time)
                pending, pending_det, pending_time = 0, 0.0, 0.0
                if status != OK:
                    break
        else:
            # a singular Jacobian: column 0 alone carries on, the others restart
            r = math.sqrt(A[0, 0] * A[0, 0] + A[1, 0] * A[1, 0] + A[2, 0] * A[2, 0]
                          + A[3, 0] * A[3, 0])  # fmt: skip
            if not math.isfinite(r):  # a grazing contact (V_n = 0): no derivative
                status = NON_FINITE
                break
            if r > 0.0:
                for k in range(4):
                    A[k, 0] = A[k, 0] / r
                out_log[j] += math.log(r)
            else:
                out_collapses[j] += 1
                A[0, 0], A[1, 0], A[2, 0], A[3, 0] = 0.0, 1.0, 0.0, 0.0
            complete_frame(A)
            if kind == STICK:
                spec.sticks[j] += 1
        if before != STICK:
            out_collisions[j] += 1
        out_time[j] = t
        if t > t_ends[j]:
            j += 1
    if pending > 0 and (status == OK or status == STUCK_FOREVER):
        qr = _qr_step(A, logs, pending_window, out_log, spec, pending, pending_det, pending_time)
        status = status if qr == OK else qr
    frame[:, :] = A
    return (periods, phase, tile, xi, vx, vyrel, kind), status


@njit(cache=True, fastmath=FMA, inline="always", error_model="numpy")
def _qr_step(A, logs, j, out_log, spec, pending, pending_det, pending_time):
    """The QR step of ``billiard_tangent_run``: count the ``pending`` carried events since the
    last step, their closed-form ``log |det J|`` sum ``pending_det`` and their time (s) in
    window ``j``; orthonormalise ``A`` and add ``log R_ii`` to window ``j``.  ``NON_FINITE``
    for a non-finite column (a grazing contact), else ``OK``."""
    spec.carried[j] += pending
    spec.log_det[j] += pending_det
    spec.carried_time[j] += pending_time
    orthonormalise(A, logs)
    for c in range(A.shape[1]):
        if not math.isfinite(logs[c]):
            return NON_FINITE
    out_log[j] += logs[0]
    for c in range(A.shape[1]):
        spec.log[j, c] += logs[c]
    return OK
