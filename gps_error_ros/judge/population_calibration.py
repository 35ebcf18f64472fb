"""
The best-predicting profile of a receiver: a population with the extended model within.

On held-out days and walks this class predicted best (docs/generalisation.md).
``gps_error calibrate --population`` writes it; ``--within ar`` keeps the
Gaussian AR within. Every recording trains (no part is held out): the
extended model's effects are chosen as ``diagnose`` chooses them (tested on
the errors about their 300-s blocks' means, kept by blocked cross-validation),
and the population section is fitted about its lag as the judged class is
(:class:`~gps_error_ros.judge.population_class.PopulationClass`). The rest of
the profile (velocity, stated accuracy, gross failures, availability, the
allowance for other days) is :func:`~gps_error_ros.fit.calibration.calibrate`'s.
"""

from dataclasses import replace
from collections.abc import Callable, Sequence

from gps_error_ros.diagnose.pipeline import fit_split
from gps_error_ros.fit.calibration import calibrate, CalibrationResult
from gps_error_ros.fit.gross_failures import without_rows
from gps_error_ros.fit.population_fit import (DAY_RATIO, occasions, segment_weights,
                                              with_day_allowance)
from gps_error_ros.judge.generalise import split_between
from gps_error_ros.judge.population_class import PopulationClass, within_part
from gps_error_ros.traces.trace_io import join_recordings, recordings_of, Trace

__all__ = ['calibrate_best', 'STAGES']

#: Stages of the extended fit (diagnose's steps 2-5), for a progress bar.
STAGES = 5


def calibrate_best(trace: Trace | Sequence[Trace], day_allowance: float = DAY_RATIO,
                   seed: int = 0, done: Callable[[], object] | None = None) -> CalibrationResult:
    """
    Return the population profile with the extended model within, fitted to every recording.

    Parameters
    ----------
    trace
        One recording, or several of one receiver.
    day_allowance
        As :func:`~gps_error_ros.fit.calibration.calibrate`'s, for a
        population of one occasion; 0: none.
    seed
        The seed of the effect selection's simulations.
    done
        Called after each of the extended fit's :data:`STAGES` stages (a progress bar).

    Returns
    -------
    CalibrationResult
        :func:`~gps_error_ros.fit.calibration.calibrate`'s result with a
        population, its ``within`` the extended model. Without enough blocks
        for a population (3 of 300 s) it is that result as it is: no section,
        and the evidence says why.

    """
    result = calibrate(trace, population=True, day_allowance=day_allowance)
    if result.population is None or result.population.population is None:
        return result
    # the recordings as calibrate fitted them: its failures, found once, left out
    kept = [without_rows(t, f.mask) for t, f in zip(recordings_of(trace), result.failures)]
    joined = join_recordings(kept)
    end = float(joined.t[-1]) + 1.0
    split = split_between(joined, end, end, 'every recording trains')
    weights = segment_weights(kept, split.train.t)
    inner = replace(split, train=within_part(split.train), train_weights=None)
    within = fit_split(joined.name, inner, seed=seed, done=done).extended
    pop = PopulationClass(split.train, within, split.truth, weights)
    fit = pop.fit
    if fit.population is None:          # the lag's removal left too little spread
        return result
    fit.evidence['occasions'] = len(set(occasions(kept)))
    axes = (pop.axes[0], pop.axes[1])
    fit.evidence['within_order'] = {'north': axes[0].order, 'east': axes[1].order}
    fit.evidence['within'] = {
        'model': 'the extended model, fitted on the errors about their blocks\' means '
                 '(gps_error_ros/judge/population_calibration.py)',
        'effects': list(within.effects)}
    fit = with_day_allowance(fit, day_allowance)
    return replace(result, population=fit, within=(axes, within.effects_obj()))
