"""The symbol route of bbdyn/approx/green_kubo.py is the series derived in
derivations/green_kubo_symbols.py (symbols relative to h_0)."""

import numpy as np
import pytest
from derivation_loader import load_derivation
from extras import require

from bbdyn.approx import JumpData, green_kubo
from bbdyn.approx.green_kubo import _series, _words

sp = require("sympy", "derivations")

N = 3


@pytest.fixture(scope="module")
def derivation():
    return load_derivation("green_kubo_symbols")


def test_symbol_form_equals_correlation_form_on_any_joint_distribution(derivation):
    correlation, symbols = derivation.joint_check(N)
    for a, b in zip(correlation, symbols, strict=True):
        assert sp.expand(a - b) == 0


def test_derived_D_1_and_D_2_are_the_documented_ones(derivation):
    m = derivation
    D_0 = m.d**2 / (2 * m.tau)
    D = m.symbol_series(2)
    assert sp.expand(D[1] - (D_0 + 2 * D_0 * (m.p("f") - m.p("b")))) == 0
    step = m.p("ff") - m.p("fb") + m.p("bf") - m.p("bb")
    assert sp.expand(D[2] - (D[1] + 2 * D_0 * step)) == 0


def test_code_symbol_series_is_the_derived_expression(derivation):
    """The code's word order and series, fed sympy word probabilities, give D_0..D_3 exactly."""
    m = derivation
    d = np.array([m.d], dtype=object)  # shape (1,): the code indexes its scale array
    signed = [sp.Integer(1)]
    for k in range(1, N + 1):
        signed.append(sp.Add(*[m.sign_last(w) * m.p(w) for w in _words(k)]))
    _, d_sym = _series(np.zeros(N + 1, dtype=object), np.array(signed, dtype=object), 1.0, d)
    derived = [D.subs(m.tau, 1) for D in m.symbol_series(N)]
    for got, want in zip(d_sym[0], derived, strict=True):
        assert sp.expand(sp.nsimplify(got) - want) == 0, (got, want)


def test_code_word_labels_are_the_derived_words(derivation):
    for k in range(1, N + 1):
        assert sorted(_words(k)) == sorted(derivation.words(k))


def _markov_walk(rng, n_particles=60, n_jumps=80, keep=(0.8, 0.3)):
    """Jumps +-1 that keep the previous direction with probability keep[0] after a kept
    step and keep[1] after a reversal (memory two: the word probabilities are not products)."""
    jumps, times = [], []
    for _ in range(n_particles):
        steps, last = [int(rng.choice((-1, 1)))], 1
        for _ in range(n_jumps - 1):
            last = 1 if rng.random() < keep[0 if last == 1 else 1] else -1
            steps.append(last)
        jumps.append(np.cumprod(steps))
        times.append(np.sort(rng.uniform(0.0, 10.0, n_jumps)))
    return JumpData.from_particles(jumps, times, 10.0, 2.0)


def test_derived_series_with_measured_word_probabilities_gives_the_code_D_n(derivation):
    """On a synthetic walk with memory, the derived D_0..D_3 evaluated at the measured
    p_w and tau equal both routes of the code to rounding."""
    m = derivation
    data = _markov_walk(np.random.default_rng(11))
    res = green_kubo(data, N, n_boot=2, table_len=N)
    values = {m.p(w): res.p(w)[0] for k in range(1, N + 1) for w in m.words(k)}
    values |= {m.d: data.d, m.tau: res.tau}
    derived = np.array([float(D.subs(values)) for D in m.symbol_series(N)])
    np.testing.assert_allclose(res["D_n_symbols"][: N + 1], derived, rtol=1e-13)
    np.testing.assert_allclose(res.D_n[: N + 1], derived, rtol=1e-13)
