"""
The covariance a fix's consumer needs: of the error about the truth, mean included.

A profile's error has a mean (``delta / (1 - sum phi)`` per axis: DS5's is
about 3.5 m north) and, given the state a step before, a predictable part.
A consumer of a fix (robot_localization, a V2P receiver) cannot know either:
it takes the fix as the truth plus a zero-mean error of the stated
covariance. So what the node and ``gps_error simulate`` state by default is
the mean square error matrix about the truth, ``E[e e^T] = C + m m^T``:

* ``stationary``: ``C`` the error's stationary covariance, ``m`` its
  stationary mean;
* ``conditional``: ``C`` the covariance of this fix's error given the state a
  step before, ``m`` the error expected given that state
  (``predictive_mean``: the mean plus the predictable part);
* ``reported``: the circle the phone states, plus the profile's stationary
  ``m m^T`` (the phone does not know its bias).

``covariance_about: mean`` (node) or ``--covariance-about mean``
(``simulate``) states ``C`` alone, the error's spread about its mean.

:class:`AboutTruth` wraps a model so that ``stationary_cov`` and
``predictive_cov`` are these matrices; its errors, states and draws are the
model's own, bit for bit.
"""

import numpy as np

from gps_error_ros.model.protocol import ErrorModel, Inputs, S
from gps_error_ros.model.state import FloatArray, Inner, Keys, Numbers
from gps_error_ros.model.wrapped import Wrapper

#: What a stated covariance covers: the error about the truth, or about its mean.
COVARIANCE_ABOUT = ('truth', 'mean')


def model_about_truth(covariance_about: str, covariance_mode: str) -> bool:
    """
    Return whether the model's own covariances are to be about the truth (:class:`AboutTruth`).

    So they are when ``covariance_about`` is truth, except in ``reported``
    mode: there the phone's radius follows the plain predictive scale and
    the mean is added after (:func:`reported_mean`).
    """
    return covariance_about == 'truth' and covariance_mode != 'reported'


def reported_mean(model: ErrorModel[S], covariance_about: str) -> FloatArray | None:
    """Return the mean whose ``m m^T`` a stated radius's covariance gets (None: about the mean)."""
    return np.asarray(model.mean) if covariance_about == 'truth' else None


def mean_square(cov: Numbers, mean: Numbers) -> FloatArray:
    """Return ``cov + mean mean^T`` for covariances (..., 2, 2) and means (..., 2)."""
    mean = np.asarray(mean, dtype=float)
    return np.asarray(cov, dtype=float) + mean[..., :, None] * mean[..., None, :]


class AboutTruth(Wrapper[Inner, Inner]):
    """
    A model whose stated covariances are about the truth (see the module docstring).

    Its state is the wrapped model's own (``core``): errors, states and draws
    are the model's, bit for bit; only the stated covariances change.
    """

    @property
    def core(self) -> ErrorModel[Inner]:
        """Return the wrapped model (the one ``inner`` names)."""
        return self.inner

    def part(self, state: Inner) -> Inner:
        """Return ``state``: the wrapped model's, unchanged."""
        return state

    def empty_state(self, n: int) -> Inner:
        """Return the wrapped model's state of ``n`` agents, all zeros."""
        return self.core.empty_state(n)

    def initial_state(self, keys: Keys, index: int, inputs: Inputs = None) -> Inner:
        """Draw the wrapped model's state at model step ``index``."""
        return self.core.initial_state(keys, index, inputs)

    def state_after(self, keys: Keys, start: int, step: int, inputs: Inputs = None) -> Inner:
        """Return the wrapped model's state at ``step`` of a run started at ``start``."""
        return self.core.state_after(keys, start, step, inputs)

    def advance(self, state: Inner, keys: Keys, index: int,
                inputs: Inputs = None) -> FloatArray:
        """Advance the wrapped model's state in place; return its errors."""
        return self.core.advance(state, keys, index, inputs)

    @property
    def stationary_cov(self) -> FloatArray:
        """Return the stationary mean square error matrix (2, 2)."""
        return mean_square(self.core.stationary_cov, self.core.mean)

    def mean_step_cov(self) -> FloatArray:
        """Return the mean one-step mean square error matrix, the stationary mean's included."""
        return mean_square(self.core.mean_step_cov(), self.core.mean)

    def predictive_cov(self, state: Inner, first: bool = False) -> FloatArray:
        """Return each agent's mean square error matrix of the next error given ``state``."""
        return mean_square(self.core.predictive_cov(state, first),
                           self.core.predictive_mean(state, first))
