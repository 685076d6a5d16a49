"""Numba kernels: plain functions on floats and arrays, no Python objects.

Modules here import only numpy, math, numba and each other (tests/test_architecture.py).
"""
