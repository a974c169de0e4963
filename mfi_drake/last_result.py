"""`LastResult`: the last result of a calculation, kept with its inputs."""

import numpy as np


class LastResult:
    """Remembers the last result of a calculation that depends on nothing but
    its inputs (numpy arrays or numbers, compared by value).

    Why: the logger evaluates the whole controller chain at the end of every
    integrator step; the integrator then starts the next step by taking the
    state vector mutably, which marks every cache entry out of date, and
    evaluates the derivatives at that same state once more. Comparing the
    inputs' bytes turns that repeat (a fifth of a flight's evaluations) into
    a lookup. Disabled for non-float systems: the bytes of an AutoDiffXd
    array do not hold its values, let alone its derivatives.
    """

    def __init__(self, enabled: bool = True):
        self._enabled = enabled
        self._last = (None, None)  # (key, result), replaced as one

    def __call__(self, calc, *inputs):
        """calc(*inputs), computed again only when an input has changed."""
        if not self._enabled:
            return calc(*inputs)
        key = [x.tobytes() if isinstance(x, np.ndarray) else x for x in inputs]
        last_key, result = self._last
        if key != last_key:
            result = calc(*inputs)
            self._last = (key, result)
        return result
