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

#: What a stated covariance covers: the error about the truth, or about its mean.
COVARIANCE_ABOUT = ('truth', 'mean')


def mean_square(cov, mean):
    """Return ``cov + mean mean^T`` for covariances (..., 2, 2) and means (..., 2)."""
    mean = np.asarray(mean, dtype=float)
    return np.asarray(cov, dtype=float) + mean[..., :, None] * mean[..., None, :]


class AboutTruth:
    """A model whose stated covariances are about the truth (see the module docstring)."""

    def __init__(self, core):
        self.core = core

    def __getattr__(self, name):
        # errors, states, draws, moments other than the covariances: the model's own
        return getattr(self.core, name)

    @property
    def stationary_cov(self):
        """Return the stationary mean square error matrix (2, 2)."""
        return mean_square(self.core.stationary_cov, self.core.mean)

    @property
    def stationary_sd(self):
        """Return the root mean square error per axis."""
        return np.sqrt(np.diag(self.stationary_cov))

    def mean_step_cov(self):
        """Return the mean one-step mean square error matrix, the stationary mean's included."""
        return mean_square(self.core.mean_step_cov(), self.core.mean)

    def predictive_cov(self, state, first=False):
        """Return each agent's mean square error matrix of the next error given ``state``."""
        return mean_square(self.core.predictive_cov(state, first),
                           self.core.predictive_mean(state, first))
