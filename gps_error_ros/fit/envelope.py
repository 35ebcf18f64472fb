"""
A measured statistic beside the same statistic of simulated traces.

The one way the package reports whether a measured value is a plausible
draw of a model: the simulated median and central 95 % range, and the
measured value's percentile among the simulated values (a tie counts half).
``validate``, ``compare`` and the reported-accuracy check all use it.
"""

from typing import TypedDict

import numpy as np

from gps_error_ros.model.availability import runs_without_fix
from gps_error_ros.model.state import Numbers

#: A gap of this many missing grid steps or more is an outage (the phone had
#: no fix); a shorter one is a message dropped on the way (a logger's or a
#: transport's loss), not a property of the place.
MIN_OUTAGE_STEPS = 2


class Envelope(TypedDict):
    """A measured value against the simulated traces' values of the same statistic."""

    #: The measured value.
    measured: float
    #: The simulated values' median, and their 2.5 and 97.5 % points.
    sim_median: float
    sim_lo: float
    sim_hi: float
    #: Where the measured value falls among the simulated ones, % (a tie counts half).
    percentile: float


def envelope(measured: float, simulated: Numbers, tol: float = 0.0) -> Envelope:
    """
    Return ``measured`` against the values ``simulated`` of the same statistic.

    A dict with ``measured``, ``sim_median``, ``sim_lo`` and ``sim_hi`` (the
    2.5 and 97.5 % points) and ``percentile``; values within ``tol`` (relative
    to max(1, |measured|)) of the measured one count as ties.
    """
    v = np.asarray(simulated, dtype=float)
    m = float(measured)
    tie = np.abs(v - m) <= tol * max(1.0, abs(m))
    lo, mid, hi = np.percentile(v, [2.5, 50.0, 97.5])
    return {'measured': m, 'sim_median': float(mid), 'sim_lo': float(lo),
            'sim_hi': float(hi),
            'percentile': float(100.0 * (np.mean((v < m) & ~tie) + 0.5 * np.mean(tie)))}


def inside(row: Envelope) -> bool:
    """Return whether an :func:`envelope` row's measured value is inside its 95 % range."""
    return bool(row['sim_lo'] <= row['measured'] <= row['sim_hi'])


def outage_stats(mask: Numbers, min_steps: int = MIN_OUTAGE_STEPS) -> tuple[int, int, float, int]:
    """
    Return (outages, steps in outages, median and longest outage) of a fix mask.

    An outage is a run of ``min_steps`` or more steps without a fix on the
    1 Hz grid (the rule of ``calibrate``); shorter runs are dropped messages.
    The count gives the rate, the other three the durations (0 without an
    outage).
    """
    long = [r for r in runs_without_fix(mask) if r >= min_steps]
    if not long:
        return 0, 0, 0.0, 0
    return len(long), int(sum(long)), float(np.median(long)), int(max(long))


#: the outage measures, in the order of :func:`outage_stats`
OUTAGE_MEASURES = ('outages', 'steps_in_outages', 'median_outage_steps',
                   'longest_outage_steps')


def outage_envelopes(mask: Numbers, simulated_masks: Numbers
                     ) -> dict[str, Envelope]:
    """Return {measure: envelope} of a measured fix mask against simulated ones."""
    measured = outage_stats(mask)
    sims = np.array([outage_stats(m) for m in simulated_masks], dtype=float)
    return {name: envelope(measured[j], sims[:, j])
            for j, name in enumerate(OUTAGE_MEASURES)}
