"""Validated, immutable model parameters (docs/model.md, "Units and defaults").

Units: lengths in mm, times in s, mass 1 kg.  ``Params`` is validated once, at
construction; kernels never see it, they take ``Params.kernel()``, a NamedTuple
of plain floats that numba accepts.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import asdict, dataclass, replace
from typing import NamedTuple

from bbdyn.core.plate import release_window

__all__ = ["Params", "KernelParams", "check_params"]


class KernelParams(NamedTuple):
    """Plain floats for the numba kernels (units: mm, s).

    ``A, w, g, alpha, beta, R, d`` as in docs/model.md; the rest are derived once
    here so that kernels never recompute them: ``gamma = A w^2 / g``,
    ``curv_bound = g + A w^2`` (a bound on ``|d^2 gap / dt^2|`` of the flat ball),
    ``c0 = sqrt(R^2 - d^2/4)`` (depth of the arc centres below the wedges),
    ``period = 2 pi / w``, ``arc5_bound = 15 R^2 h (3 R^2 + 4 h^2) / c0^9`` (h = d/2;
    a bound on the fifth derivative of the arc height on a tile, ``billiard.tiny_hop``) and
    the release window ``release_r <= phase < release_e`` (rad) where ``sin(phase) <
    -1/Gamma`` (``plate.release_window``: both -1 for Gamma <= 1), so that no flight or
    stick computes its arcsine again.

    Tilt (docs/model.md, "Tilt"): ``g`` here is the component of gravity along the floor's
    normal, ``g cos(phi)`` (the whole of g, bit for bit, at phi = 0), and ``gamma``,
    ``curv_bound`` and the release window are formed with it; ``g_t = g sin(phi)`` is the
    component along the floor, pulling towards +x (mm/s^2), and ``tilt_curv = |g_t| (d/2) /
    c0`` bounds its contribution ``-b'(xi) g_t`` to the gap's second derivative (the arc's
    slope is at most ``(d/2) / c0``, at the wedges).  Both are 0 at phi = 0.

    ``eta``: the noise amplitude of the restitution coefficients, read by the particle loop
    only (``core.noise``).
    """

    A: float
    w: float
    g: float
    alpha: float
    beta: float
    R: float
    d: float
    gamma: float
    curv_bound: float
    c0: float
    period: float
    arc5_bound: float
    release_r: float
    release_e: float
    g_t: float
    tilt_curv: float
    eta: float


#: Supported range ``(low, high)`` of each dimensional field, in its unit (Hz, mm, mm/s^2);
#: ``R`` must also exceed ``d/2``.  Generous: each reaches at least four decades beyond
#: the reference set-up (f near 50-95 Hz, A = 0.1 mm, g = 9800 mm/s^2, d = 2 mm,
#: R = 25 mm; R = 1e9 mm is a flat floor), while every derived quantity stays far from
#: floating-point overflow (w^2, A w^2, Gamma = A w^2 / g, 1/f and R^2 all below 1e30).
LIMITS = {
    "f": (1e-6, 1e6),
    "A": (0.0, 1e6),
    "g": (1e-6, 1e12),
    "d": (1e-6, 1e6),
    "R": (0.0, 1e12),
}
UNITS = {"f": "Hz", "A": "mm", "g": "mm/s^2", "d": "mm", "R": "mm"}
#: Largest tilt ``|phi|`` (degrees): a few times the arcs' own slope at the defaults (about
#: 2.3 degrees), well inside the range where a particle resting on an arc is held by static
#: friction in the model (docs/model.md, "Tilted floor").
PHI_MAX = 15.0
RANGE_REASON = "bbdyn's supported range: generous, and bounded so that Gamma, h and R^2 stay finite"


def _check_real(name: str, value) -> float:
    """``value`` as a finite float; TypeError unless a real number (bools and text are not)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(
            f"{name} must be a real number (int or float), got {type(value).__name__} {value!r}"
        )
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"{name} must be finite, got {value}")
    return value


def _check_range(name: str, value: float) -> None:
    """Refuse a dimensional field outside ``LIMITS``: ValueError naming the range and why."""
    low, high = LIMITS[name]
    if not low <= value <= high:
        raise ValueError(
            f"{name} must be in [{low:g}, {high:g}] {UNITS[name]}, got {value:g} ({RANGE_REASON})"
        )


@dataclass(frozen=True, kw_only=True)
class Params:
    """Parameters of the bouncing ball (billiard), with the defaults of docs/model.md.

    Parameters
    ----------
    f : float
        Driving frequency in Hz, in [1e-6, 1e6]. No default: it is the scanned parameter.
    A : float
        Floor vibration amplitude in mm, in [0, 1e6]; default 0.1.
    g : float
        Gravitational acceleration in mm/s^2, in [1e-6, 1e12]; default 9800.
    alpha, beta : float
        Normal and tangential restitution coefficients, in [0, 1]; defaults 0.5, 0.99.
    R : float
        Radius of the circular scatterers in mm, in (d/2, 1e12]; default 25.
    d : float
        Width of one scatterer (tile) in mm, in [1e-6, 1e6]; default 2.
    phi : float
        Tilt of the whole apparatus in degrees, in [-15, 15]; default 0 (docs/model.md,
        "Tilt").  The floor vibrates along its own normal; gravity has the component
        ``g cos(phi)`` against that normal and ``g sin(phi)`` along the floor, towards +x
        for phi > 0.
    eta : float
        Noise amplitude of the restitution coefficients, in [0, 1]; default 0 (deterministic).
        For eta > 0 every flight's collision draws its own alpha and beta, uniform on
        ``c +- eta min(c, 1 - c)`` (docs/model.md, "Noise"; ``bbdyn.core.noise``): modelled
        by the ensemble runs (``ensemble``, ``classify``, the scans) only.

    Every field must be a real number (bools and strings are refused with a
    TypeError); the ranges of the dimensional fields are ``LIMITS``.

    Examples
    --------
    >>> p = Params(f=58.0)
    >>> round(p.gamma, 4)
    1.3552
    >>> Params(f=58.0, alpha=1.2)
    Traceback (most recent call last):
    ...
    ValueError: alpha must be in [0, 1], got 1.2
    """

    f: float
    A: float = 0.1
    g: float = 9800.0
    alpha: float = 0.5
    beta: float = 0.99
    R: float = 25.0
    d: float = 2.0
    phi: float = 0.0
    eta: float = 0.0

    def __post_init__(self) -> None:
        for name in ("f", "A", "g", "alpha", "beta", "R", "d", "phi", "eta"):
            object.__setattr__(self, name, _check_real(name, getattr(self, name)))
        for name in ("alpha", "beta", "eta"):
            value = getattr(self, name)
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"{name} must be in [0, 1], got {value}")
        for name in LIMITS:
            _check_range(name, getattr(self, name))
        if not abs(self.phi) <= PHI_MAX:
            raise ValueError(
                f"phi must be in [-{PHI_MAX:g}, {PHI_MAX:g}] degrees, got {self.phi:g} "
                "(a tilt of a few degrees is the model's range)"
            )
        if self.R <= self.d / 2:
            raise ValueError(
                f"R must be > d/2 = {self.d / 2:g} mm, got {self.R:g}: at R = d/2 the arcs are "
                "semicircles with vertical tangents at the wedges; use a larger R"
            )
        slope = math.degrees(math.atan2(self.d / 2, math.sqrt(self.R**2 - self.d**2 / 4)))
        if abs(self.phi) + slope >= 90.0:
            raise ValueError(
                f"|phi| + the arcs' steepest slope ({slope:.4g} degrees) must stay below 90 "
                f"degrees, got phi = {self.phi:g}: the floor would overhang; use a larger R"
            )

    # ---- derived quantities -------------------------------------------------
    @property
    def w(self) -> float:
        """Angular frequency w = 2 pi f (rad/s)."""
        return 2.0 * math.pi * self.f

    @property
    def period(self) -> float:
        """Driving period 1/f (s)."""
        return 1.0 / self.f

    @property
    def gamma(self) -> float:
        """Dimensionless acceleration Gamma = A w^2 / g."""
        return self.A * self.w**2 / self.g

    @property
    def h(self) -> float:
        """Bump height h = R - sqrt(R^2 - d^2/4) = (d^2/4) / (R + sqrt(R^2 - d^2/4)) (mm).

        The second form has no cancellation for R >> d (the flat limit).
        """
        return (self.d**2 / 4) / (self.R + math.sqrt(self.R**2 - self.d**2 / 4))

    @property
    def s_max(self) -> float:
        """Arc length of one scatterer, 2 R asin(d / 2R) (mm)."""
        return 2.0 * self.R * math.asin(self.d / (2.0 * self.R))

    @property
    def f_gamma_one(self) -> float:
        """Frequency (Hz) at which Gamma = 1, sqrt(g/A) / (2 pi); inf for A = 0."""
        return math.inf if self.A == 0 else math.sqrt(self.g / self.A) / (2.0 * math.pi)

    @property
    def g_n(self) -> float:
        """Component of gravity against the floor's normal, g cos(phi) (mm/s^2)."""
        return self.g * math.cos(math.radians(self.phi))

    @property
    def g_t(self) -> float:
        """Component of gravity along the floor, g sin(phi), towards +x (mm/s^2)."""
        return self.g * math.sin(math.radians(self.phi))

    def replace(self, **changes: float) -> Params:
        """A copy with some fields changed (validated again)."""
        return replace(self, **changes)

    def to_dict(self) -> dict[str, float]:
        """The primary fields as a plain dict (for metadata and JSON)."""
        return asdict(self)

    def kernel(self, noise: bool = False) -> KernelParams:
        """The plain-float NamedTuple the numba kernels take.

        ``noise=True`` for the callers that model ``eta > 0`` (the particle loop of the
        ensemble runs); any other refuses ``eta > 0`` (ValueError), since its kernels would
        ignore it.
        """
        if self.eta > 0 and not noise:
            raise ValueError(
                f"eta = {self.eta:g}: random restitution is modelled by the ensemble runs only "
                "(ensemble, classify and the scans); this computation is deterministic, use eta = 0"
            )
        w = self.w
        c0 = math.sqrt(self.R**2 - self.d**2 / 4)
        R2, half, c0_2 = self.R * self.R, 0.5 * self.d, c0 * c0
        arc5 = 15.0 * R2 * half * (3.0 * R2 + 4.0 * half * half) / (c0_2 * c0_2 * c0_2 * c0_2 * c0)
        g = self.g_n  # cos(0) = 1: the same bits as g untilted
        gamma = self.A * w**2 / g
        # the kernels' own compiled function: the same bits as computing it inside them
        release_r, release_e = release_window(gamma)
        return KernelParams(
            A=self.A,
            w=w,
            g=g,
            alpha=self.alpha,
            beta=self.beta,
            R=self.R,
            d=self.d,
            gamma=gamma,
            curv_bound=g + self.A * w * w,
            c0=c0,
            period=1.0 / self.f,
            arc5_bound=arc5,
            release_r=release_r,
            release_e=release_e,
            g_t=self.g_t,
            tilt_curv=abs(self.g_t) * half / c0,
            eta=self.eta,
        )


def check_params(params: Params) -> None:
    """Refuse parameters the billiard kernel does not model.

    ``beta = 1`` with ``alpha < 1``: chattering then ends in sliding along the
    arc (tangential velocity never damped), which bbdyn does not model.
    """
    if not isinstance(params, Params):
        raise TypeError(f"params must be a bbdyn.Params, got {type(params).__name__}")
    if params.beta == 1.0 and params.alpha < 1.0:
        raise ValueError(
            "beta = 1 with alpha < 1 is not supported: chattering would end in sliding "
            f"along the arc, which is not modelled; use beta < 1 (got alpha={params.alpha})"
        )
