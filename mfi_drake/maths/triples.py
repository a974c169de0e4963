"""3-vectors as triples of Python scalars (float or AutoDiffXd; see
`so3.entries`), the arithmetic of `fields`, `terminal` and `baselines`.

A numpy operation on a 3-vector costs more than the arithmetic it does, and
the simulation evaluates the fields thousands of times a flight. Each public
field function converts at its boundary only; the arithmetic, and its order,
is that of the vector form in its docstring. (`compiled` swaps `_zeros` and
`_zero3` for their float forms by name.)
"""

import numpy as np


def _zeros(like) -> tuple:
    """A zero triple of like's scalar type (AutoDiffXd zeros for AutoDiffXd)."""
    return (0.0, 0.0, 0.0) if isinstance(like, float) else (0.0 * like,) * 3


def _zero3(like) -> np.ndarray:
    """A zero 3-vector of like's scalar type (AutoDiffXd zeros for AutoDiffXd)."""
    if isinstance(like, np.ndarray) and like.dtype == np.float64:
        return np.zeros(3)
    return np.array([0.0 * like[0]] * 3)


def _cross(a, b) -> tuple:
    a0, a1, a2 = a
    b0, b1, b2 = b
    return (a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0)


def _scaled(a, k) -> tuple:
    """a · k (k a scalar)."""
    return (a[0] * k, a[1] * k, a[2] * k)


def _divided(a, k) -> tuple:
    """a / k (k a scalar)."""
    return (a[0] / k, a[1] / k, a[2] / k)


def _ramp(x, zero, one):
    """0 at x = zero, 1 at x = one, linear between, clipped."""
    return min(1.0, max(0.0, (x - zero) / (one - zero)))
