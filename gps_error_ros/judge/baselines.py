"""
The model classes simulators use today, against ours, on the same held-out data.

Every class is fitted on a diagnosis's training part by conditional Gaussian
maximum likelihood (least squares, as the base model), and scored on the
same held-out samples (the same conditioning samples per segment are left
unscored for all) by the same measures as ``gps_error diagnose``:

* ``white noise + bias`` (CARLA, Gazebo): per axis a constant and white noise;
* ``AR(1)``: a first-order Gauss-Markov process sampled at 1 Hz (Webots);
* ``ARMA(1,1)``: a Gauss-Markov bias plus white noise, which sampled at 1 Hz
  is an ARMA(1,1) (hector_gazebo_plugins, PX4's SITL GPS);
* ``AR(3), paper``: the paper's fixed order;
* ``AR(p), PACF``: the order calibration picks (the diagnosis's base model);
* ``extended``: the diagnosis's extended model, with fix availability
  (outages, as ``calibrate`` fits them) from the training part's gaps.

Where the held-out part or the extended class has outages, their number and
total length join every class's calibrated measures; a class without
availability simulates a fix at every step.
"""

from collections.abc import Mapping
import math
from typing import Any

import numpy as np
from scipy import optimize, signal

from gps_error_ros.diagnose.common import LOG2PI
from gps_error_ros.fit.fidelity import (calibrated_fidelity, fidelity_of, part_fix_mask,
                                        part_steps, run_masks, score_differences,
                                        simulate_part, with_outages)
from gps_error_ros.diagnose.mean import condition_count
from gps_error_ros.diagnose.models import fit_model
from gps_error_ros.fit.holdout import Part, Split
from gps_error_ros.fit.calibration import availability_from_mask
from gps_error_ros.fit.envelope import outage_stats
from gps_error_ros.judge.results import SplitComparison
from gps_error_ros.model import streams
from gps_error_ros.model.availability import availability_from_dict, WithAvailability
from gps_error_ros.model.state import BoolArray, FloatArray, IntArray, Numbers

#: Simulated traces, each a list of segments (n_s, 2), north/east error, m.
Traces = list[list[FloatArray]]

CLASSES = ('white noise + bias', 'AR(1)', 'ARMA(1,1)', 'AR(3), paper',
           'AR(p), PACF', 'extended')


def _scored(part: Part, m0: int) -> list[IntArray]:
    """Return per-segment index arrays of the scored samples."""
    return [np.arange(m0, len(e)) for e in part.err]


def _gauss_ll(r: FloatArray, var: Numbers) -> FloatArray:
    return -0.5 * (LOG2PI + np.log(var) + r * r / var)


class WhiteBias:
    """Constant plus white Gaussian noise, per axis."""

    def fit(self, train: Part) -> 'WhiteBias':
        """Fit on the training part."""
        x = np.concatenate(train.err)
        self.mu, self.var = x.mean(axis=0), x.var(axis=0)
        return self

    def logpdf(self, part: Part, m0: int) -> FloatArray:
        """Return per-sample log densities of the scored samples."""
        out = [(_gauss_ll(e[idx] - self.mu, self.var)).sum(axis=1)
               for e, idx in zip(part.err, _scored(part, m0))]
        return np.concatenate(out)

    def simulate(self, part: Part, sims: int, rng: np.random.Generator) -> Traces:
        """Return ``sims`` traces on ``part``'s segments."""
        return [[self.mu + rng.standard_normal((len(e), 2)) * np.sqrt(self.var)
                 for e in part.err] for _ in range(sims)]


class Arma11:
    """ARMA(1,1) per axis, conditional Gaussian ML (innovations from 0)."""

    def fit(self, train: Part, m0: int) -> 'Arma11':
        """Fit on the training part, scoring from ``m0`` in each segment."""
        self.params: list[tuple[float, float, float, float]] = []
        for a in range(2):
            segs = [e[:, a] for e in train.err]
            x = np.concatenate(segs)
            phi0 = np.clip(np.corrcoef(x[:-1], x[1:])[0, 1], -0.9, 0.99)

            def sse(v: FloatArray, segs: list[FloatArray] = segs) -> float:
                mu, phi, theta = v[0], math.tanh(v[1]), math.tanh(v[2])
                tot = 0.0
                for s in segs:
                    w = self._innov(s, mu, phi, theta)
                    tot += float(w[m0:] @ w[m0:])
                return tot

            res = optimize.minimize(sse, [x.mean(), math.atanh(phi0), 0.0],
                                    method='Nelder-Mead',
                                    options={'xatol': 1e-6, 'fatol': 1e-8,
                                             'maxiter': 4000})
            mu, phi, theta = res.x[0], math.tanh(res.x[1]), math.tanh(res.x[2])
            n = sum(max(0, len(s) - m0) for s in segs)
            self.params.append((mu, phi, theta, res.fun / n))
        return self

    @staticmethod
    def _innov(s: Numbers, mu: float, phi: float, theta: float) -> FloatArray:
        # w_t = (x_t - mu) - phi (x_{t-1} - mu) - theta w_{t-1}, w_0 = x_0 - mu
        y = np.asarray(s) - mu
        e = np.r_[y[0], y[1:] - phi * y[:-1]]
        return signal.lfilter([1.0], [1.0, theta], e)

    def logpdf(self, part: Part, m0: int) -> FloatArray:
        """Return per-sample log densities of the scored samples."""
        out = []
        for e, idx in zip(part.err, _scored(part, m0)):
            ll = np.zeros(len(idx))
            for a, (mu, phi, theta, var) in enumerate(self.params):
                w = self._innov(e[:, a], mu, phi, theta)
                ll += _gauss_ll(w[idx], var)
            out.append(ll)
        return np.concatenate(out)

    def simulate(self, part: Part, sims: int, rng: np.random.Generator,
                 burn: int = 500) -> Traces:
        """Return ``sims`` traces on ``part``'s grid, gaps kept (stationary start)."""
        steps = part_steps(part)
        n = int(steps[-1][-1]) + 1 + burn
        out: Traces = []
        for _ in range(sims):
            cols = []
            for mu, phi, theta, var in self.params:
                w = rng.standard_normal(n) * math.sqrt(var)
                cols.append(mu + signal.lfilter([1.0, theta], [1.0, -phi], w)[burn:])
            x = np.stack(cols, axis=1)
            out.append([x[s] for s in steps])
        return out


#: class -> its name in ``gps_error compare``'s JSON
KEYS = {'white noise + bias': 'white_bias', 'AR(1)': 'ar1', 'ARMA(1,1)': 'arma11',
        'AR(3), paper': 'ar3_paper', 'AR(p), PACF': 'ar_p', 'extended': 'extended'}


def _classes(diag: Any, sims: int, seed: int,
             m0: int | None = None) -> dict[str, tuple[FloatArray, Traces]]:
    """
    Return {class: (held-out log densities, simulated traces)}, same samples.

    ``diag`` is anything with the ``split``, ``base`` and ``extended`` of a
    diagnosis: a :class:`~gps_error_ros.diagnose.pipeline.Diagnosis` or the cheaper
    :class:`~gps_error_ros.diagnose.pipeline.FittedModels`. ``m0``: samples per segment
    conditioned on (default: what the base and extended models need).
    """
    train, test, truth = diag.split.train, diag.split.test, diag.split.truth
    if m0 is None:
        m0 = condition_count(diag.base.orders, diag.extended.orders)
    rng = np.random.default_rng(seed)
    wb = WhiteBias().fit(train)
    arma = Arma11().fit(train, m0)
    out = {'white noise + bias': (wb.logpdf(test, m0), wb.simulate(test, sims, rng)),
           'ARMA(1,1)': (arma.logpdf(test, m0), arma.simulate(test, sims, rng))}
    for label, model in (('AR(1)', fit_model(train, (1, 1), (), truth)),
                         ('AR(3), paper', fit_model(train, (3, 3), (), truth)),
                         ('AR(p), PACF', diag.base),
                         ('extended', diag.extended)):
        out[label] = (model.score(test, truth, m0)[0],
                      simulate_part(model, test, truth, sims, seed))
    n = {len(v[0]) for v in out.values()}
    if len(n) != 1:
        raise AssertionError(f'models scored on different samples: {n}')
    return {k: out[k] for k in CLASSES}


def training_outages(split: Split, model: Any, sims: int, seed: int = 0) -> BoolArray | None:
    """
    Return a class's simulated fix masks over the held-out span, (sims, span).

    Availability is fitted on the training part's gaps as ``calibrate``
    fits it, each recording's own (:func:`~gps_error_ros.fit.fidelity.run_masks`: the time
    between joined recordings is no outage); None when the training part has
    no outage (the class then simulates none). The masks come from the
    agents' ``outage`` streams of the keys :func:`~gps_error_ros.fit.fidelity.simulate_part`
    uses.
    """
    section = availability_from_mask(run_masks(split.train)).section
    if section is None:
        return None
    avail = WithAvailability(model, availability_from_dict(section))
    keys = streams.agent_keys(seed, [f'sim{i}' for i in range(sims)])
    return avail.simulate_fix(keys, part_fix_mask(split.test).size)


def compare(diag: Any, sims: int = 100, seed: int = 0) -> dict[str, dict[str, Any]]:
    """
    Fit every class on the diagnosis's training part; score on its test part.

    Returns a dict: class -> ``heldout_nll_per_sample``,
    ``nll_minus_best`` (its NLL minus the lowest class's, paired on the
    same samples, with a 95 % interval:
    :func:`~gps_error_ros.fit.fidelity.score_differences`),
    the summary fidelity measures of ``diagnose`` and ``calibrated`` (the
    measures of :func:`~gps_error_ros.fit.fidelity.calibrated_fidelity`, with the outage
    measures where the held-out part or the extended class has outages),
    all on the same samples.
    """
    test = diag.split.test
    masks = training_outages(diag.split, diag.extended.simulator(), sims, seed)
    outages = masks is not None or outage_stats(part_fix_mask(test))[0] > 0
    classes = _classes(diag, sims, seed)
    lls = {label: ll for label, (ll, _) in classes.items()}
    against = score_differences(lls, max(lls, key=lambda k: float(np.mean(lls[k]))), seed)
    out: dict[str, dict[str, Any]] = {}
    for label, (ll, traces) in classes.items():
        calibrated = calibrated_fidelity(test, traces)
        if outages:
            calibrated = with_outages(calibrated, test,
                                      masks if label == 'extended' else None)
        out[label] = {'heldout_nll_per_sample': float(-ll.mean()),
                      'nll_minus_best': against[label],
                      **fidelity_of(test, traces), 'calibrated': calibrated}
    return out


def split_comparison(name: str, split: Split, compared: Mapping[str, Mapping[str, Any]],
                     sims: int) -> SplitComparison:
    """Return ``gps_error compare``'s result of a :func:`compare` result on ``split``."""
    return SplitComparison(
        name, split.train.n, split.test.n, sims,
        {KEYS[k]: {'heldout_nll_per_sample': v['heldout_nll_per_sample'],
                   'nll_minus_best': v['nll_minus_best'],
                   'fidelity': {key: v['calibrated'][key] for key in ('inside_95', 'measures')}}
         for k, v in compared.items()})
