"""
One profile against a profile per zone, on the same held-out part.

``gps_error compare INPUT --zones MAP`` adds this to the class table: on the
diagnosis's training part, ``calibrate`` (Yule-Walker, the PACF order) fits
one profile on every sample and, as ``calibrate --zones`` does, one profile
per zone with at least :data:`~gps_error_ros.fit.zone_calibration.MIN_ZONE_SAMPLES`
training samples (the others keep the one profile). Both are then judged on
the held-out part exactly as the classes are:

* one-step held-out NLL per sample, each sample predicted by the profile of
  the zone it is in (the same conditioning samples left unscored for both);
* simulated traces along the held-out grid (``sims`` agents, each zone's
  parameters where the truth is, :mod:`gps_error_ros.model.zoned`), and the
  calibrated fidelity measures with ``inside_95``;
* the same NLL per zone, to see where a zone's own profile helps or hurts,
  and the NLL improvement per sample with its 95 % interval (moving-block
  bootstrap over the held-out samples, blocks of 30).
"""

from collections.abc import Sequence
from typing import Any

import numpy as np

from gps_error_ros.diagnose.common import LOG2PI
from gps_error_ros.fit.fidelity import (block_bootstrap_mean, calibrated_fidelity,
                                        part_steps)
from gps_error_ros.fit.holdout import Part, Split
from gps_error_ros.fit.calibration import CalibrationError
from gps_error_ros.fit.yule_walker import fit_axis
from gps_error_ros.fit.zone_calibration import MIN_ZONE_SAMPLES
from gps_error_ros.model import streams
from gps_error_ros.model.ar_model import ARErrorModel, AXES
from gps_error_ros.model.geodesy import offset
from gps_error_ros.model.protocol import opaque
from gps_error_ros.model.state import FloatArray, IntArray
from gps_error_ros.model.stepping import StepsPerFix
from gps_error_ros.model.zoned import simulate_along, WithZones
from gps_error_ros.model.zones import ZoneMap


def part_zones(part: Part, zone_map: ZoneMap, origin: tuple[float, float]) -> list[IntArray]:
    """Return the zone of every sample of ``part``, per segment."""
    out: list[IntArray] = []
    for tr in part.truth:
        lat, lon = offset(origin[0], origin[1], tr[:, 0], tr[:, 1])
        out.append(zone_map.lookup(lat, lon))
    return out


def _fit(segments: Sequence[FloatArray]) -> ARErrorModel:
    """Return an ARErrorModel fitted per axis on ``segments`` (list of (n, 2))."""
    fits = [fit_axis([s[:, a] for s in segments if len(s)], axis=ax)
            for a, ax in enumerate(AXES)]
    return ARErrorModel(fits[0].params, fits[1].params)


def _zone_segments(part: Part, zones: Sequence[IntArray], z: int) -> list[FloatArray]:
    """Return ``part``'s errors in zone ``z``, cut where the walk leaves it."""
    out: list[FloatArray] = []
    for e, zz in zip(part.err, zones):
        mask = zz == z
        if not mask.any():
            continue
        idx = np.flatnonzero(mask)
        out.extend(np.split(e[idx], np.flatnonzero(np.diff(idx) > 1) + 1))
    return out


def fit_zoned(train: Part, zones: Sequence[IntArray], zone_map: ZoneMap,
              min_samples: int = MIN_ZONE_SAMPLES
              ) -> tuple[ARErrorModel, list[ARErrorModel], dict[str, dict[str, Any]]]:
    """
    Return (one model, [model per zone, the one model last], {zone: fit note}).

    A zone with fewer than ``min_samples`` training samples, or whose fit is
    refused, uses the one model (note says why).
    """
    one = _fit(train.err)
    models: list[ARErrorModel] = []
    notes: dict[str, dict[str, Any]] = {}
    all_zones = np.concatenate(zones)
    for z, name in enumerate(zone_map.names):
        n = int(np.sum(all_zones == z))
        if n < min_samples:
            models.append(one)
            notes[name] = {'train_samples': n, 'fitted': False,
                           'reason': f'{n} training samples, fewer than {min_samples}'}
            continue
        try:
            models.append(_fit(_zone_segments(train, zones, z)))
            notes[name] = {'train_samples': n, 'fitted': True,
                           'orders': [int(models[-1].axes[a].order) for a in range(2)]}
        except CalibrationError as exc:
            models.append(one)
            notes[name] = {'train_samples': n, 'fitted': False, 'reason': str(exc)}
    return one, models + [one], notes


def _loglik(part: Part, zones: Sequence[IntArray], models: Sequence[ARErrorModel],
            m0: int) -> tuple[FloatArray, IntArray]:
    """Return (log density, zone) of every scored sample: one-step Gaussian per zone."""
    ll: list[float] = []
    where: list[int] = []
    for e, zz in zip(part.err, zones):
        for t in range(m0, len(e)):
            m = models[zz[t]]
            p = m.order
            dev = e[t - p:t][::-1] - m.mean          # (p, 2): lags 1..p
            pred = m.mean + np.sum(m.phi.T * dev, axis=0)
            var = np.diag(m.innovation_cov)
            r = e[t] - pred
            ll.append(float(np.sum(-0.5 * (LOG2PI + np.log(var) + r * r / var))))
            where.append(int(zz[t]))
    return np.array(ll), np.array(where, dtype=np.int64)


def _simulate(part: Part, zones: Sequence[IntArray], models: Sequence[ARErrorModel],
              sims: int, seed: int) -> list[list[FloatArray]]:
    """Return ``sims`` traces along ``part``'s grid, each step in its zone's model."""
    steps = part_steps(part)
    keys = streams.agent_keys(seed, [f'sim{i}' for i in range(sims)])
    zoned = opaque(WithZones([opaque(m) for m in models]))
    x = simulate_along(StepsPerFix(zoned), keys, np.concatenate(steps),
                       np.concatenate(zones))
    bounds = np.cumsum([0] + [len(s) for s in steps])
    return [[x[b0:b1, i] for b0, b1 in zip(bounds[:-1], bounds[1:])] for i in range(sims)]


def compare_zones(split: Split, zone_map: ZoneMap, origin: tuple[float, float],
                  sims: int = 100, seed: int = 0) -> dict[str, Any]:
    """Return the ``zones`` section of ``compare --zones`` (see module doc)."""
    train_z = part_zones(split.train, zone_map, origin)
    test_z = part_zones(split.test, zone_map, origin)
    one, per_zone, notes = fit_zoned(split.train, train_z, zone_map)
    m0 = max(m.order for m in per_zone)
    out: dict[str, Any] = {'min_zone_samples': MIN_ZONE_SAMPLES, 'zones': notes,
                           'classes': {}}
    lls: dict[str, tuple[FloatArray, IntArray]] = {}
    for name, models in (('one_profile', [one] * len(per_zone)), ('per_zone', per_zone)):
        ll, where = _loglik(split.test, test_z, models, m0)
        lls[name] = (ll, where)
        traces = _simulate(split.test, test_z, models, sims, seed)
        fid = calibrated_fidelity(split.test, traces)
        out['classes'][name] = {'heldout_nll_per_sample': float(-ll.mean()),
                                'fidelity': {'inside_95': fid['inside_95'],
                                             'measures': fid['measures']}}
    gain = lls['per_zone'][0] - lls['one_profile'][0]
    mean, lo, hi = block_bootstrap_mean(gain, seed=seed)
    # NLL lower per zone by this much per sample; 95 % moving-block bootstrap
    out['nll_improvement'] = {'per_sample': mean, 'ci95': [lo, hi]}
    names = list(zone_map.names) + ['outside']
    for z in np.unique(lls['one_profile'][1]):
        sel = lls['one_profile'][1] == z
        entry = out['zones'].setdefault(names[z], {'fitted': False})
        entry['heldout_samples'] = int(sel.sum())
        for name in ('one_profile', 'per_zone'):
            entry[f'heldout_nll_{name}'] = float(-lls[name][0][sel].mean())
    return out
