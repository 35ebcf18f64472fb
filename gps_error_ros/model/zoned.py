"""
Errors whose parameters follow the zone each agent is in.

With a zone map (:mod:`zones`) an agent's error process takes, at every
model step, the parameters of the zone its truth is in. The transition:

* The state carries over and only the parameters change. The state holds
  the last ``P`` errors themselves (mean included, ``P`` the largest order of
  any zone), and a step in zone ``z`` is that zone's recursion on them::

      e(k) = mu_z + sum_i phi_z,i (e(k - i) - mu_z) + s w(k)

  with ``w(k)`` from the agent's stream at step ``k`` (the same draw in
  every zone) and ``s`` the zone's effects (coupling, heavy tails,
  regimes). So the error is continuous across a boundary: it moves to the
  new zone's mean and spread at the new zone's own pace, and after a few of
  its correlation times it is a draw from the new zone's stationary law.
* Variance regimes: an agent entering a zone with regimes draws its regime
  from that zone's stationary regime law (the stream's initial-regime draw at
  that step); while it stays, the regime follows the zone's chain.
* Which zone a model step belongs to: the zone of the truth that serves
  the agent's fix at that step. Steps an agent gets no fix for (no truth, a
  later attach) are advanced with the zone of the next fix's truth; an
  agent's first steps are drawn from the stationary law of the zone of its
  first fix. Given the truth, everything is a pure function of (seed, agent
  name, step): the node, ``simulate`` and every shard agree.

Errors are computed when an agent's fix is made, not when the step comes
due, because the zone is known only once the truth for the step is.
"""

import numpy as np

from gps_error_ros.model import streams
from gps_error_ros.model.ar_model import state_and_cov
from gps_error_ros.model.effects import ExtendedModel
from gps_error_ros.model.zones import OUTSIDE, zone_models


def _has_regimes(model):
    return isinstance(model, ExtendedModel) and model.scales.size > 1


class ZonedErrors:
    """
    Per-slot error state over zone models, advanced lazily per agent.

    Parameters
    ----------
    models : list
        The error models of the zones, in the zone map's order, then the
        default model last (zone index ``OUTSIDE`` = -1 picks it). Zones
        with the same model object are stepped together, and moving between
        them is not entering a new zone (the regime carries on).
    conditional_cov : bool
        Covariance of each error given the state a step before (the node's
        ``covariance_mode`` conditional); else the zone's stationary one.

    """

    def __init__(self, models, n=0, conditional_cov=False):
        assert OUTSIDE == -1
        self.models = []                       # distinct models
        index = {}
        for m in models:
            if id(m) not in index:
                index[id(m)] = len(self.models)
                self.models.append(m)
        # zone index (OUTSIDE = -1 is the last entry) -> distinct model
        self.model_of_zone = np.array([index[id(m)] for m in models], dtype=np.int64)
        self.order = max(m.order for m in self.models)
        self.conditional_cov = conditional_cov
        self.stationary = np.array([m.stationary_cov for m in self.models])
        self.start = None
        self._alloc(n)

    def _alloc(self, n):
        self.err = np.zeros((n, 2, self.order))    # last P errors, newest first
        self.regime = np.zeros(n, dtype=np.int64)
        self.zone = np.zeros(n, dtype=np.int64)    # the distinct model in use
        self.step = np.zeros(n, dtype=np.int64)    # last model step advanced
        self.started = np.zeros(n, dtype=bool)
        self.cov = np.zeros((n, 2, 2))             # of the current error

    @property
    def n(self):
        """Return the number of slots."""
        return self.started.size

    def grow(self, n):
        """Add ``n`` slots (not started)."""
        old = (self.err, self.regime, self.zone, self.step, self.started, self.cov)
        self._alloc(n)
        self.err, self.regime, self.zone, self.step, self.started, self.cov = [
            np.concatenate([a, b]) for a, b in zip(
                old, (self.err, self.regime, self.zone, self.step, self.started, self.cov))]

    def keep(self, mask):
        """Keep only the slots where ``mask`` is True (in order)."""
        for name in ('err', 'regime', 'zone', 'step', 'started', 'cov'):
            setattr(self, name, getattr(self, name)[mask])

    def restart(self, start, rows=slice(None)):
        """Forget ``rows`` (all by default); runs count from model step ``start``."""
        self.start = int(start)
        self.started[rows] = False

    def forget(self, rows):
        """Forget ``rows``: their next fix starts them again from the run's start."""
        self.started[rows] = False

    def errors(self, rows, keys, step, zones):
        """
        Return the error, shape (m, 2), and covariance (m, 2, 2) of ``rows`` at a step.

        ``keys`` are the rows' stream keys and ``zones`` the zone index of
        each row's truth now (``OUTSIDE`` for the default). Rows behind are
        advanced to model step ``step`` first (see the module doc).
        """
        rows = np.asarray(rows, dtype=np.int64)
        keys = np.asarray(keys, dtype=np.uint64)
        zones = self.model_of_zone[np.asarray(zones, dtype=np.int64)]
        if self.start is None:
            raise ValueError('ZonedErrors.restart(start) was not called')
        fresh = ~self.started[rows]
        if fresh.any():
            self._begin(rows[fresh], keys[fresh], step, zones[fresh])
        if np.any(self.step[rows] > step):
            raise ValueError(f'model step {step} is before the last step served '
                             f'({int(self.step[rows].max())})')
        behind = np.flatnonzero(self.step[rows] < step)
        if behind.size:
            r, k, z = rows[behind], keys[behind], zones[behind]
            for s in range(int(self.step[r].min()) + 1, step + 1):
                due = self.step[r] < s
                self._advance(r[due], k[due], s, z[due])
        cov = self.cov[rows] if self.conditional_cov else self.stationary[self.zone[rows]]
        return self.err[rows, :, 0].copy(), cov

    def _groups(self, zones):
        for z in np.unique(zones):
            yield int(z), np.flatnonzero(zones == z)

    def _begin(self, rows, keys, step, zones):
        """Start ``rows`` at ``step``: the state of a run from the start in one zone."""
        for z, sel in self._groups(zones):
            model, r, k = self.models[z], rows[sel], keys[sel]
            if self.conditional_cov:
                state, cov = state_and_cov(model, k, self.start, step)
                self.cov[r] = cov
            else:
                state = model.state_after(k, self.start, step)
            p = model.order
            self.err[r] = model.mean[None, :, None]       # lags beyond p: the mean
            self.err[r, :, :p] = state[:, :, :p] + model.mean[None, :, None]
            self.regime[r] = state[:, 0, p] if _has_regimes(model) else 0
            self.zone[r] = z
            self.step[r] = step
            self.started[r] = True

    def _advance(self, rows, keys, step, zones):
        """Advance ``rows`` (one step behind) to ``step`` with their zones' recursions."""
        for z, sel in self._groups(zones):
            model, r, k = self.models[z], rows[sel], keys[sel]
            p = model.order
            tmp = model.empty_state(r.size)
            tmp[:, :, :p] = self.err[r, :, :p] - model.mean[None, :, None]
            if _has_regimes(model):
                regime = self.regime[r].copy()
                entering = self.zone[r] != z
                if entering.any():
                    u = streams.uniform_pairs(k[entering], streams.DOMAIN_INIT_REGIME,
                                              step)[:, 0]
                    regime[entering] = np.searchsorted(model.cum_pi, u, side='right')
                tmp[:, 0, p] = regime
            if self.conditional_cov:
                self.cov[r] = model.predictive_cov(tmp)
            e = model.advance(tmp, k, step)
            self.err[r, :, 1:] = self.err[r, :, :-1]
            self.err[r, :, 0] = e
            self.regime[r] = tmp[:, 0, p] if _has_regimes(model) else 0
            self.zone[r] = z
            self.step[r] = step


def zoned_errors(zone_map, profile, covariance_mode='stationary'):
    """
    Return (default profile, its model, ``(zone_map, ZonedErrors)``) for a run.

    The default profile is the map's ``default_profile``, else ``profile``;
    its model gives what is not the error process (availability) and the
    error outside every zone.
    """
    default, models = zone_models(zone_map, profile)
    return default, default.model(), (zone_map, ZonedErrors(
        models, conditional_cov=covariance_mode == 'conditional'))


def simulate_along(zoned, keys, steps, zones):
    """
    Return errors (n samples, agents, 2) simulated along sampled steps in zones.

    ``steps`` (n,) increasing model steps from 0 where a trace has samples,
    ``zones`` (n,) the zone of each sample. Every agent runs continuously
    from step 0; a step without a sample takes the zone of the next sample
    (the rule of the module doc). ``zoned`` is a fresh :class:`ZonedErrors`.
    """
    steps = np.asarray(steps, dtype=np.int64)
    span = int(steps[-1]) + 1
    nxt = np.minimum(np.searchsorted(steps, np.arange(span)), steps.size - 1)
    zone_at = np.asarray(zones, dtype=np.int64)[nxt]
    keys = np.asarray(keys, dtype=np.uint64)
    zoned.grow(keys.size - zoned.n)
    zoned.restart(0)
    rows = np.arange(keys.size)
    out = np.empty((steps.size, keys.size, 2))
    j = 0
    for k in range(span):
        e = zoned.errors(rows, keys, k, np.full(keys.size, zone_at[k]))[0]
        while j < steps.size and steps[j] == k:
            out[j] = e
            j += 1
    return out
