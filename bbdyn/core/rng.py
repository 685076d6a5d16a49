"""Counter-based random numbers: Philox-4x32-10 (Salmon et al., SC11, "Parallel random
numbers: as easy as 1, 2, 3").

A counter-based generator has no state: the output is a fixed function of a 128-bit
counter and a 64-bit key (ten rounds of 32-bit multiplications and xors), so the numbers a
particle draws depend only on (key, particle, draw index), never on the order in which
particles, threads, processes or devices run, nor on how a run is cut into chunks.  Plain
scalar integer arithmetic on ``uint64`` values holding 32-bit words (the products of two
32-bit words fit): the same functions compile for the CPU and for CUDA
(``core.targets``), without numpy calls or allocation.

``philox4x32`` is the published algorithm and reproduces its known-answer vectors
(Random123's ``kat_vectors``, tests/test_noise.py); ``unit_double`` turns two of its
words into a double in [0, 1) with 53 random bits.
"""

import numpy as np
from numba import njit

from bbdyn.core.tolerances import FMA

__all__ = ["philox4x32", "unit_double"]

#: Philox-4x32 multipliers and Weyl key increments (the published constants).
PHILOX_M0 = np.uint64(0xD2511F53)
PHILOX_M1 = np.uint64(0xCD9E8D57)
PHILOX_W0 = np.uint64(0x9E3779B9)
PHILOX_W1 = np.uint64(0xBB67AE85)
PHILOX_ROUNDS = 10
MASK32 = np.uint64(0xFFFFFFFF)
SHIFT32 = np.uint64(32)
#: ``unit_double``: the top 27 and 26 bits of two words make a 53-bit integer.
SHIFT5, SHIFT6 = np.uint64(5), np.uint64(6)
TWO_26 = 67108864.0
TWO_M53 = 1.0 / 9007199254740992.0


@njit(cache=True, fastmath=FMA, inline="always")
def philox4x32(c0, c1, c2, c3, k0, k1):
    """Philox-4x32-10 of the counter ``(c0, c1, c2, c3)`` and key ``(k0, k1)``.

    Every argument and result is a 32-bit word held in a ``uint64``.  Returns the four
    output words; e.g. counter 0 and key 0 give ``0x6627e8d5 0xe169c58d 0xbc57ac4c
    0x9b00dbd8``.
    """
    for r in range(PHILOX_ROUNDS):
        if r > 0:  # the key schedule: a Weyl sequence, bumped before every round but the first
            k0 = (k0 + PHILOX_W0) & MASK32
            k1 = (k1 + PHILOX_W1) & MASK32
        p0 = PHILOX_M0 * c0
        p1 = PHILOX_M1 * c2
        c0, c1, c2, c3 = (
            (p1 >> SHIFT32) ^ c1 ^ k0,
            p1 & MASK32,
            (p0 >> SHIFT32) ^ c3 ^ k1,
            p0 & MASK32,
        )
    return c0, c1, c2, c3


@njit(cache=True, fastmath=FMA, inline="always")
def unit_double(a, b):
    """A double in [0, 1) from two 32-bit words (``uint64``): ``(a >> 5) 2^26 + (b >> 6)``
    over 2^53, every multiple of 2^-53 equally likely."""
    return (float(a >> SHIFT5) * TWO_26 + float(b >> SHIFT6)) * TWO_M53
