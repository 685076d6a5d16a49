"""Truncated Green-Kubo expansion of the diffusion coefficient (docs/model.md, section 4).

With the jumps ``h_k`` (mm) of a particle's jump sequence and ``tau`` the escape
time (``random_walk.escape_time``),

    D_n = (1/tau) ( <h_0^2>/2 + sum_{k=1..n} <h_0 h_k> ),     n = 0, 1, ..., nmax.

Correlation route (exact for any jump lengths): ``<h_0 h_k>`` is the mean of
``h_j h_{j+k}`` over all pairs ``j`` of one particle's sequence, then the plain
mean over the particles that have more than ``k`` jumps (their number is
reported per lag).  ``tau`` is pooled over all particles, jumping or not.

Symbol route (the +-1 alphabet).  The symbol convention of bbdyn, used by the
code, ``docs/green_kubo.md`` and the notebooks: the jumps ``h_1, h_2, ...`` that
follow a jump ``h_0`` are labelled ``f`` (same direction as ``h_0``) or ``b``
(opposite to ``h_0``), every symbol relative to ``h_0``, not to the jump before
it.  From ``h_0 = +1``, the jumps ``+1 -1 -1`` read ``fbb`` (relative to the jump
before they would read ``fbf``).  ``p_w`` for a word ``w`` of length k (``p_f``,
``p_b``, ``p_ff``, ``p_fb``, ...) is the probability that the k jumps after a
jump carry the symbols ``w``, conditioned on that jump (either direction: both
are pooled).  Since ``h_0 h_k = d^2 (+1 if the last symbol is f, -1 if b)`` for
unit jumps (derivation: ``derivations/green_kubo_symbols.py``),

    D_n = D_0 (1 + 2 sum_{k=1..n} sum_{|w| = k} sign(w_k) p_w),   D_0 = d^2 / (2 tau) = D_rw,

e.g. ``D_1 = D_0 + 2 D_0 (p_f - p_b)``, ``D_2 = D_1 + 2 D_0 (p_ff - p_fb + p_bf - p_bb)``.
Jumps with ``|h| > d`` enter the symbol route only through their direction; the
fraction of such jumps is reported, and when it is zero the two routes agree to
rounding.  The symbol route is computed up to ``SYMBOL_MAX_LEN`` (2^k words per lag).

Errors: bootstrap over particles (whole jump sequences are resampled, so the
correlations within a sequence are kept), reproducible from ``seed`` through
``np.random.SeedSequence``.
"""

from __future__ import annotations

import math
import time

import numpy as np

from bbdyn.approx.jumps import JumpData
from bbdyn.approx.random_walk import escape_time, jump_length_distribution
from bbdyn.results import Result, make_meta

__all__ = ["GreenKuboResult", "green_kubo", "SYMBOL_MAX_LEN"]

#: Longest symbol word: the per-particle tables have 2^k columns at lag k.
SYMBOL_MAX_LEN = 10


def _words(length: int) -> list[str]:
    """All words of ``length`` symbols in code order (first symbol most significant, f = 0)."""
    return [
        "".join("b" if (code >> (length - 1 - m)) & 1 else "f" for m in range(length))
        for code in range(2**length)
    ]


def _per_particle(data: JumpData, nmax: int, table_len: int):
    """Per-particle jump correlations and symbol statistics.

    Returns ``corr`` (N, nmax+1): mean of ``(h_j/d)(h_{j+k}/d)`` over a particle's
    pairs; ``table`` (N, n_words): word probabilities for lengths 1..table_len;
    ``signed`` (N, n_sym+1): ``sum_w sign(w_k) p_w`` per particle (1 at k = 0);
    ``sym_mean`` (n_sym+1,): the same from the particle-averaged tables.  Entries
    of particles with at most k jumps are NaN.
    """
    n_part, counts = data.n_particles, data.counts
    pid = data.particle_index
    jumps = data.jumps
    n_sym = min(nmax, SYMBOL_MAX_LEN)
    corr = np.full((n_part, nmax + 1), np.nan)
    signed = np.full((n_part, n_sym + 1), np.nan)
    signed[counts > 0, 0] = 1.0
    sym_mean = np.full(n_sym + 1, np.nan)
    sym_mean[0] = 1.0 if np.any(counts > 0) else np.nan
    tables = []
    sgn = np.sign(jumps)
    code = np.zeros(jumps.size, dtype=np.int64)
    for k in range(nmax + 1):
        windows = counts - k
        has = windows > 0
        # pairs (j, j + k) inside one particle: the CSR blocks are contiguous
        m = max(jumps.size - k, 0)  # no pair at all beyond the total number of jumps
        same = pid[:m] == pid[k:]
        owner = pid[:m][same]
        prod = (jumps[:m] * jumps[k:])[same].astype(np.float64)
        sums = np.bincount(owner, weights=prod, minlength=n_part)
        corr[has, k] = sums[has] / windows[has]
        if k == 0 or k > n_sym:
            continue
        # append symbol k (1 = backward relative to h_0) as the least significant bit
        code = 2 * code[:m] + (sgn[k:] != sgn[:m])
        hist = np.bincount(owner * 2**k + code[same], minlength=n_part * 2**k)
        probs = np.full((n_part, 2**k), np.nan)
        probs[has] = hist.reshape(n_part, 2**k)[has] / windows[has, None]
        sign_last = 1.0 - 2.0 * (np.arange(2**k) & 1)
        signed[:, k] = probs @ sign_last
        if np.any(has):
            sym_mean[k] = np.mean(probs[has], axis=0) @ sign_last
        if k <= table_len:
            tables.append(probs)
    table = np.concatenate(tables, axis=1) if tables else np.zeros((n_part, 0))
    return corr, table, signed, sym_mean


def _weighted_means(values: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Means over particles of ``values`` (N, m), ignoring NaN, per row of ``weights`` (B, N)."""
    ok = np.isfinite(values)
    with np.errstate(invalid="ignore", divide="ignore"):
        return (weights @ np.where(ok, values, 0.0)) / (weights @ ok)


def _series(corr_mean, signed_mean, tau, d):
    """``D_n`` from both routes; arrays (..., nmax+1) and (..., n_sym+1); tau (...,)."""
    scale = (d**2 / np.asarray(tau, dtype=np.float64))[..., None]
    partial = np.concatenate(
        (corr_mean[..., :1] / 2, corr_mean[..., :1] / 2 + np.cumsum(corr_mean[..., 1:], axis=-1)),
        axis=-1,
    )
    d_corr = scale * partial
    d_sym = scale / 2 * (1.0 + 2.0 * np.cumsum(signed_mean, axis=-1) - 2.0 * signed_mean[..., :1])
    return d_corr, d_sym


def _check_int(name: str, value, low: int, high: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise ValueError(f"{name} must be an integer, got {value!r}")
    if not low <= value <= high:
        raise ValueError(f"{name} must be in [{low}, {high}], got {value}")
    return int(value)


def green_kubo(
    data: JumpData,
    nmax: int = 10,
    *,
    n_boot: int = 1000,
    seed: int = 0,
    table_len: int | None = None,
    D_einstein: float | None = None,
    D_einstein_err: float | None = None,
    meta: dict | None = None,
) -> GreenKuboResult:
    """Truncated Green-Kubo ``D_n`` (mm^2/s), n = 0..nmax, by both routes (module docstring).

    Parameters
    ----------
    data : JumpData
        Jump sequences of an ensemble.
    nmax : int
        Highest truncation order (>= 1); the symbol route stops at ``SYMBOL_MAX_LEN``.
    n_boot : int
        Bootstrap resamples over particles for the standard errors (>= 2).
    seed : int
        Seed of the bootstrap (``np.random.SeedSequence(seed)``): same seed, same errors.
    table_len : int, optional
        Longest word in the stored symbol table (default ``min(4, nmax)``).
    D_einstein, D_einstein_err : float, optional
        The Einstein D (mm^2/s) at the same parameters, stored and drawn as a band.
    meta : dict, optional
        Extra metadata (e.g. ``make_meta(params, seed)`` of the simulation).

    Returns
    -------
    GreenKuboResult
        Without any jump ``tau = inf`` and ``D_n = 0`` (trapped) with NaN errors.

    Examples
    --------
    >>> data = JumpData.from_particles([[1, 1, -1, -1], [-1, 1, 1, 1]],
    ...                                [[1., 2., 3., 4.], [1., 2., 3., 4.]], t_total=4.0, d=1.0)
    >>> res = green_kubo(data, nmax=2, n_boot=10)
    >>> np.round(res.D_n, 4).tolist(), round(res.p("f")[0], 4)
    ([0.5, 0.8333, 0.3333], 0.6667)
    """
    start = time.perf_counter()
    if not isinstance(data, JumpData):
        raise ValueError(f"data must be a bbdyn.approx.JumpData, got {type(data).__name__}")
    nmax = _check_int("nmax", nmax, 1, 100_000)
    n_boot = _check_int("n_boot", n_boot, 2, 10**7)
    seed = _check_int("seed", seed, 0, 2**63 - 1)
    n_sym = min(nmax, SYMBOL_MAX_LEN)
    table_len = _check_int("table_len", min(4, nmax) if table_len is None else table_len, 1, n_sym)
    # an Einstein slope estimate may come out slightly negative where nothing diffuses
    if D_einstein is not None and not math.isfinite(float(D_einstein)):
        raise ValueError(f"D_einstein must be finite, got {D_einstein}")
    if D_einstein_err is not None and not (
        math.isfinite(float(D_einstein_err)) and float(D_einstein_err) >= 0
    ):
        raise ValueError(f"D_einstein_err must be finite and >= 0 mm^2/s, got {D_einstein_err}")

    esc = escape_time(data)
    lengths = jump_length_distribution(data)
    corr, table, signed, sym_mean = _per_particle(data, nmax, table_len)
    ones = np.ones((1, data.n_particles))
    corr_mean = _weighted_means(corr, ones)[0]
    table_mean = _weighted_means(table, ones)[0]
    d_corr, d_sym = _series(corr_mean, sym_mean, esc.tau, data.d)

    rng = np.random.default_rng(np.random.SeedSequence(seed))
    weights = rng.multinomial(
        data.n_particles, np.full(data.n_particles, 1.0 / data.n_particles), size=n_boot
    ).astype(np.float64)
    with np.errstate(divide="ignore"):
        tau_b = data.t_total * data.n_particles / (weights @ data.counts)
    corr_b = _weighted_means(corr, weights)
    d_corr_b, d_sym_b = _series(corr_b, _weighted_means(signed, weights), tau_b, data.d)

    def spread(samples):
        # NaN where a resample has no particle with enough jumps: too few to tell
        with np.errstate(invalid="ignore"):
            return np.std(samples, axis=0, ddof=1)

    def padded(values):
        return np.r_[values, np.full(nmax - n_sym, np.nan)]

    arrays = {
        "n": np.arange(nmax + 1),
        "D_n": d_corr,
        "D_n_err": spread(d_corr_b),
        "D_n_symbols": padded(d_sym),
        "D_n_symbols_err": padded(spread(d_sym_b)),
        "corr": corr_mean * data.d**2,
        "corr_err": spread(corr_b) * data.d**2,
        "n_particles_used": np.sum(np.isfinite(corr), axis=0),
        "words": np.array([w for k in range(1, table_len + 1) for w in _words(k)]),
        "p_words": table_mean,
        "p_words_err": spread(_weighted_means(table, weights)),
        "jump_lengths": lengths.lengths,
        "jump_counts": lengths.counts,
    }
    if esc.n_jumps == 0:  # trapped: no displacement beyond the own trap
        arrays["D_n"] = np.zeros(nmax + 1)
        arrays["D_n_symbols"] = padded(np.zeros(n_sym + 1))
        arrays["D_n_err"] = arrays["D_n_symbols_err"] = np.full(nmax + 1, np.nan)
    info = {
        "tau": esc.tau,
        "tau_err": esc.tau_err,
        "D_rw": data.d**2 / (2 * esc.tau),
        "D_rw_err": data.d**2 / (2 * esc.tau) * esc.tau_err / esc.tau,
        "fraction_long": lengths.fraction_long,
        "n_jumps": esc.n_jumps,
        "n_particles": data.n_particles,
        "t_total": data.t_total,
        "d": data.d,
        "nmax": nmax,
        "symbol_nmax": n_sym,
        "n_boot": n_boot,
        "boot_seed": seed,
        "D_einstein": None if D_einstein is None else float(D_einstein),
        "D_einstein_err": None if D_einstein_err is None else float(D_einstein_err),
    }
    full_meta = make_meta()
    full_meta.update(meta or {})
    full_meta.update(info, gk_wall_s=time.perf_counter() - start)
    return GreenKuboResult(arrays, full_meta)


class GreenKuboResult(Result):
    """Truncated Green-Kubo series, symbol probabilities and escape time.

    Arrays: ``n``; ``D_n``, ``D_n_err`` (correlation route, mm^2/s);
    ``D_n_symbols``, ``D_n_symbols_err`` (symbol route, up to ``symbol_nmax``,
    NaN beyond); errors are NaN where some bootstrap resample holds no particle
    with more than n jumps; ``corr``, ``corr_err`` (``<h_0 h_k>``, mm^2);
    ``n_particles_used`` per lag; ``words``, ``p_words``, ``p_words_err`` (symbol
    table, symbols relative to h_0); ``jump_lengths`` (h/d), ``jump_counts``.
    Meta: ``tau``, ``tau_err`` (s), ``D_rw``, ``D_rw_err``, ``fraction_long``,
    ``D_einstein`` (or None), ...
    """

    kind = "green_kubo"

    @property
    def D_n(self) -> np.ndarray:
        """``D_n`` for n = 0..nmax (mm^2/s), correlation route."""
        return self.arrays["D_n"]

    @property
    def D_n_err(self) -> np.ndarray:
        """Bootstrap standard errors of ``D_n`` (mm^2/s)."""
        return self.arrays["D_n_err"]

    @property
    def tau(self) -> float:
        """Escape time (s)."""
        return self.meta["tau"]

    def p(self, word: str) -> tuple[float, float]:
        """Probability of the symbol word (e.g. ``"fb"``, symbols relative to h_0 as in the
        module docstring) and its bootstrap error."""
        hit = np.flatnonzero(self.arrays["words"] == word)
        if hit.size == 0:
            longest = max((len(w) for w in self.arrays["words"]), default=0)
            raise ValueError(
                f"word must be a string of 'f'/'b' of length 1..{longest}, got {word!r}"
            )
        return float(self.arrays["p_words"][hit[0]]), float(self.arrays["p_words_err"][hit[0]])

    def conditional(self, word: str) -> float:
        """Probability of the last symbol of ``word`` given the ones before (``p_w / p_w[:-1]``)."""
        if len(word) < 2:
            return self.p(word)[0]
        return self.p(word)[0] / self.p(word[:-1])[0]

    def symbol_table(self) -> str:
        """The symbol-sequence probabilities as a text table."""
        lines = ["word        p            err"]
        for w, p, e in zip(
            self.arrays["words"], self.arrays["p_words"], self.arrays["p_words_err"], strict=True
        ):
            lines.append(f"{w:<10}  {p:.6f}  {e:.6f}")
        return "\n".join(lines)

    def table(self) -> str:
        """``D_n`` of both routes with errors as a text table (mm^2/s)."""
        lines = ["n   D_n (corr)            D_n (symbols)"]
        for n, dc, ec, ds, es in zip(
            self.arrays["n"],
            self.D_n,
            self.D_n_err,
            self.arrays["D_n_symbols"],
            self.arrays["D_n_symbols_err"],
            strict=True,
        ):
            lines.append(f"{n:<3} {dc:9.4f} +- {ec:7.4f}  {ds:9.4f} +- {es:7.4f}")
        return "\n".join(lines)

    def plot(self, ax=None):
        """``D_n`` against n (both routes), ``D_rw`` and the Einstein D as a band if known."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(5, 3.5), layout="constrained")
        n = self.arrays["n"]
        ax.errorbar(n, self.D_n, yerr=self.D_n_err, fmt="o-", ms=4, capsize=2, label="$D_n$")
        ax.plot(n, self.arrays["D_n_symbols"], "s", color="k", mfc="none", ms=8, label="symbols")
        ax.axhline(self.meta["D_rw"], color="0.5", ls=":", label="$D_{rw}$")
        if self.meta.get("D_einstein") is not None:
            D, err = self.meta["D_einstein"], self.meta.get("D_einstein_err") or 0.0
            ax.axhspan(D - err, D + err, color="C1", alpha=0.3, label="Einstein $D$")
            ax.axhline(D, color="C1", lw=1)
        ax.set_xlabel("truncation order $n$")
        ax.set_ylabel("$D_n$ (mm$^2$/s)")
        ax.legend(frameon=False, fontsize="small")
        return ax
