"""Two array backends for the same plant equations: Python floats (one episode, fast per
step) and numpy arrays (many episodes at once).

The plant code is written once against this small namespace, so a single episode and a
batch run exactly the same equations. Only element-wise operations are used.
"""

from __future__ import annotations

import math
import operator

import numpy as np

__all__ = ["ScalarBackend", "NumpyBackend", "NoiseSource"]


class ScalarBackend:
    """Element-wise operations on Python floats and bools."""

    vectorised = False

    @staticmethod
    def where(cond, a, b):
        return a if cond else b

    maximum = staticmethod(max)
    minimum = staticmethod(min)
    abs = staticmethod(abs)
    sqrt = staticmethod(math.sqrt)
    hypot = staticmethod(math.hypot)
    exp = staticmethod(math.exp)
    trunc = staticmethod(math.trunc)
    not_ = staticmethod(operator.not_)

    @staticmethod
    def clip(x, lo, hi):
        return lo if x < lo else (hi if x > hi else x)

    @staticmethod
    def full(n, value):
        return value

    @staticmethod
    def asarray(x):
        return float(x)


class NumpyBackend:
    """Element-wise operations on numpy arrays of shape (n,)."""

    vectorised = True
    where = staticmethod(np.where)
    maximum = staticmethod(np.maximum)
    minimum = staticmethod(np.minimum)
    abs = staticmethod(np.abs)
    sqrt = staticmethod(np.sqrt)
    hypot = staticmethod(np.hypot)
    exp = staticmethod(np.exp)
    trunc = staticmethod(np.trunc)
    not_ = staticmethod(np.logical_not)
    clip = staticmethod(np.clip)

    @staticmethod
    def full(n, value):
        return np.full(n, value, dtype=np.asarray(value).dtype if isinstance(value, (bool, np.bool_)) else float)

    @staticmethod
    def asarray(x):
        return np.asarray(x, dtype=float)


class NoiseSource:
    """Standard normal draws from one seeded generator: a float per call (scalar backend,
    drawn in blocks for speed) or an array of shape (n,) per call (numpy backend)."""

    def __init__(self, rng: np.random.Generator, n: int, vectorised: bool, block: int = 4096):
        self._rng = rng
        self._n = n
        self._vectorised = vectorised
        self._block = block
        self._buf: list[float] = []
        self._i = 0

    def normal(self):
        """One standard normal draw per episode."""
        if self._vectorised:
            return self._rng.standard_normal(self._n)
        if self._i >= len(self._buf):
            self._buf = self._rng.standard_normal(self._block).tolist()
            self._i = 0
        v = self._buf[self._i]
        self._i += 1
        return v
