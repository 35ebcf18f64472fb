"""
A model wrapped with one state column of its own: the base of the wrappers.

:class:`~.availability.WithAvailability` (the outage state) and
:class:`~.failures.WithFailures` (this step's failure) each add what they
carry as the state's last column, ``[:, :, -1]``; the inner model keeps
``[:, :, :-1]``, its errors, moments and covariances. This class holds that
layout once: the widening of a state, and the methods that only pass the
inner model its part.
"""

import numpy as np


class OneMoreColumn:
    """An error model whose state has one more column, ``[:, :, -1]``, than ``inner``'s."""

    def __init__(self, inner):
        self.inner = inner

    def __getattr__(self, name):
        # moments, lag_s, order, axes ... are the inner model's
        return getattr(self.inner, name)

    @staticmethod
    def _wider(inner_state):
        """Return ``inner_state`` with a zero column appended."""
        state = np.zeros(inner_state.shape[:2] + (inner_state.shape[2] + 1,))
        state[:, :, :-1] = inner_state
        return state

    def empty_state(self, n):
        """Return a state array for ``n`` agents (zeros)."""
        return self._wider(self.inner.empty_state(n))

    def errors(self, state):
        """Return the current north/east errors of the inner model, (n, 2)."""
        return self.inner.errors(state[:, :, :-1])

    def predictive_cov(self, state, first=False):
        """Return the inner model's covariance of the next error (n, 2, 2)."""
        return self.inner.predictive_cov(state[:, :, :-1], first)

    def predictive_mean(self, state, first=False):
        """Return the inner model's expected next error (n, 2)."""
        return self.inner.predictive_mean(state[:, :, :-1], first)
