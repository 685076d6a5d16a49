"""Validated, immutable model parameters (MODEL.md, "Units and defaults").

Units: lengths in mm, times in s, mass 1 kg.  ``Params`` is validated once, at
construction; kernels never see it, they take ``Params.kernel()``, a NamedTuple
of plain floats that numba accepts.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace
from typing import NamedTuple

__all__ = ["Params", "KernelParams"]


class KernelParams(NamedTuple):
    """Plain floats for the numba kernels (units: mm, s).

    ``A, w, g, alpha, beta, R, d`` as in MODEL.md; the rest are derived once
    here so that kernels never recompute them: ``gamma = A w^2 / g``,
    ``curv_bound = g + A w^2`` (a bound on |d^2 gap / dt^2| of the flat ball),
    ``c0 = sqrt(R^2 - d^2/4)`` (depth of the arc centres below the wedges) and
    ``period = 2 pi / w``.
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


def _check_finite(name: str, value: float) -> float:
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a real number, got {value!r}") from None
    if not math.isfinite(value):
        raise ValueError(f"{name} must be finite, got {value}")
    return value


@dataclass(frozen=True, kw_only=True)
class Params:
    """Parameters of the bouncing ball (billiard), MODEL.md defaults.

    Parameters
    ----------
    f : float
        Driving frequency in Hz (> 0). No default: it is the scanned parameter.
    A : float
        Floor vibration amplitude in mm (>= 0); default 0.1.
    g : float
        Gravitational acceleration in mm/s^2 (> 0); default 9800.
    alpha, beta : float
        Normal and tangential restitution coefficients, in [0, 1]; defaults 0.5, 0.99.
    R : float
        Radius of the circular scatterers in mm (>= d/2); default 25.
    d : float
        Width of one scatterer (tile) in mm (> 0); default 2.

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

    def __post_init__(self) -> None:
        for name in ("f", "A", "g", "alpha", "beta", "R", "d"):
            object.__setattr__(self, name, _check_finite(name, getattr(self, name)))
        if self.f <= 0:
            raise ValueError(f"f must be > 0 Hz, got {self.f}")
        if self.A < 0:
            raise ValueError(f"A must be >= 0 mm, got {self.A}")
        if self.g <= 0:
            raise ValueError(f"g must be > 0 mm/s^2, got {self.g}")
        for name in ("alpha", "beta"):
            value = getattr(self, name)
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"{name} must be in [0, 1], got {value}")
        if self.d <= 0:
            raise ValueError(f"d must be > 0 mm, got {self.d}")
        if self.R < self.d / 2:
            raise ValueError(f"R must be >= d/2 = {self.d / 2} mm, got {self.R}")

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

    def replace(self, **changes: float) -> Params:
        """A copy with some fields changed (validated again)."""
        return replace(self, **changes)

    def to_dict(self) -> dict[str, float]:
        """The primary fields as a plain dict (for metadata and JSON)."""
        return asdict(self)

    def kernel(self) -> KernelParams:
        """The plain-float NamedTuple the numba kernels take."""
        w = self.w
        return KernelParams(
            A=self.A,
            w=w,
            g=self.g,
            alpha=self.alpha,
            beta=self.beta,
            R=self.R,
            d=self.d,
            gamma=self.gamma,
            curv_bound=self.g + self.A * w * w,
            c0=math.sqrt(self.R**2 - self.d**2 / 4),
            period=1.0 / self.f,
        )
