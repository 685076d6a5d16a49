"""The truncated Green-Kubo series D_n written with symbol-sequence probabilities.

Run ``python derivations/green_kubo_symbols.py`` to print the derivation step by
step; ``symbol_series(n)`` returns ``D_0, ..., D_n`` as sympy expressions in the
word probabilities, which the tests compare with the symbol route of
``bbdyn.approx.green_kubo`` (see ``docs/green_kubo.md`` and ``docs/model.md``).

Start: the correlation form of the truncated series (units: mm, s),

    D_n = (1/tau) ( <h_0^2>/2 + sum_{k=1..n} <h_0 h_k> ),

where h_0, h_1, ... are the jumps of one particle, read from any of its jumps
h_0 on, and tau is the escape time.

1. Unit jumps.  Every jump is +-d: ``h_k = d s_k`` with ``s_k = +-1``, so
   ``<h_0^2> = d^2`` and the first term is ``D_0 = d^2 / (2 tau)``.
2. Symbols relative to h_0.  Write ``h_0 h_k = d^2 sigma_k`` with
   ``sigma_k = s_0 s_k``: ``sigma_k = +1`` (symbol **f**, jump k goes the way of
   h_0) or ``-1`` (symbol **b**, against h_0).  Every symbol compares with h_0,
   not with the jump before it: the word ``bf`` means jump 1 went against h_0
   and jump 2 went with h_0 again.
3. Word probabilities.  ``p_w`` for a word ``w = w_1 ... w_k`` is the probability
   that ``(sigma_1, ..., sigma_k)`` spells ``w``, pooled over both directions of
   h_0.  The words of one length partition all outcomes, so
   ``<sigma_k> = sum_{|w| = k} sign(w_k) p_w`` (law of total expectation; only
   the last symbol enters).
4. Result.  ``D_n = D_0 (1 + 2 sum_{k=1..n} sum_{|w| = k} sign(w_k) p_w)``, e.g.
   ``D_1 = D_0 + 2 D_0 (p_f - p_b)``.

Check: ``joint_check(n)`` puts a general joint distribution on the 2^(n+1)
sign patterns ``(s_0, ..., s_n)`` (one free probability per pattern), computes
the correlation form directly and the symbol form from the marginals p_w of
step 3, and shows they are the same expression.
"""

from __future__ import annotations

import itertools

import sympy as sp

d, tau = sp.symbols("d tau", positive=True)


def words(length: int) -> list[str]:
    """All words of ``length`` symbols f/b, in the order f < b, first symbol most significant."""
    return ["".join(w) for w in itertools.product("fb", repeat=length)]


def p(word: str) -> sp.Symbol:
    """The probability symbol ``p_w`` of a word (e.g. ``p("fb")`` is ``p_fb``)."""
    return sp.Symbol(f"p_{word}", nonnegative=True)


def sign_last(word: str) -> int:
    """``sigma_k`` of the last symbol: +1 for f, -1 for b."""
    return 1 if word[-1] == "f" else -1


def mean_sigma(k: int) -> sp.Expr:
    """Step 3: ``<sigma_k> = <h_0 h_k> / d^2`` as a sum over the words of length k."""
    return sp.Add(*[sign_last(w) * p(w) for w in words(k)])


def symbol_series(n: int) -> list[sp.Expr]:
    """``[D_0, ..., D_n]`` (mm^2/s) from step 1-4, in d, tau and the ``p_w``."""
    D_0 = d**2 / (2 * tau)
    series = [D_0]
    for k in range(1, n + 1):
        series.append(series[-1] + d**2 * mean_sigma(k) / tau)
    return series


def joint_check(n: int) -> tuple[list[sp.Expr], list[sp.Expr]]:
    """Correlation form and symbol form of ``D_0..D_n`` on a general joint distribution.

    Returns ``(correlation, symbols)``: both expanded in the probabilities
    ``q_<pattern>`` of the sign patterns ``(s_0, ..., s_n)`` (written with
    ``+``/``-``), the last one eliminated by normalization.
    """
    patterns = list(itertools.product((1, -1), repeat=n + 1))
    q = {s: sp.Symbol("q_" + "".join("+" if x > 0 else "-" for x in s)) for s in patterns}

    def expect(fn):
        return sp.Add(*[q[s] * fn(s) for s in patterns])

    correlation = [expect(lambda s: (d * s[0]) ** 2) / (2 * tau)]
    for k in range(1, n + 1):
        correlation.append(correlation[-1] + expect(lambda s, k=k: d * s[0] * d * s[k]) / tau)

    def marginal(word):
        # p_w: sigma_j = s_0 s_j spells w for j = 1..|w|, either direction of h_0
        want = [1 if c == "f" else -1 for c in word]
        return sp.Add(
            *[q[s] for s in patterns if all(s[0] * s[j + 1] == x for j, x in enumerate(want))]
        )

    marginals = {p(w): marginal(w) for k in range(1, n + 1) for w in words(k)}
    # the q sum to 1: eliminate the last one in both forms
    last = q[patterns[-1]]
    normalize = {last: 1 - (sp.Add(*q.values()) - last)}
    symbols = [sp.expand(D.subs(marginals).subs(normalize)) for D in symbol_series(n)]
    correlation = [sp.expand(D.subs(normalize)) for D in correlation]
    return correlation, symbols


def derivation_steps(n: int = 3) -> list[tuple[str, sp.Basic]]:
    """The derivation as (explanation, sympy object) pairs, in order."""
    steps = [("D_0 = <h_0^2> / (2 tau) with h_0 = +-d", symbol_series(0)[0])]
    for k in range(1, n + 1):
        steps.append((f"<h_0 h_{k}> / d^2 = <sigma_{k}>", mean_sigma(k)))
    for k, D_k in enumerate(symbol_series(n)):
        steps.append((f"D_{k}", sp.collect(sp.expand(D_k), d**2 / tau)))
    return steps


if __name__ == "__main__":
    for text, expr in derivation_steps():
        print(f"{text}:\n    {expr}\n")
    correlation, symbols = joint_check(3)
    print(
        "correlation form = symbol form on a general joint distribution of (s_0..s_3):",
        all(sp.expand(a - b) == 0 for a, b in zip(correlation, symbols, strict=True)),
    )
