"""Numba kernels: plain functions on floats, arrays and NamedTuples of them, no Python objects.

Modules here import only numpy, math, typing (NamedTuple), numba and each other
(tests/test_architecture.py).
"""
