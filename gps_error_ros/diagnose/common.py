"""
What every step of the diagnosis shares: its constants and its error.

One place, so that the steps (split, mean, laws, family, fidelity,
baselines, pipeline) import these and not each other's internals.
"""

from collections.abc import Sequence
import math

# the held-out machinery's, which the diagnosis's steps read here too
from gps_error_ros.fit.fidelity import FIDELITY_MAX_LAG as FIDELITY_MAX_LAG  # noqa: F401
from gps_error_ros.fit.holdout import TRAIN_FRACTION as TRAIN_FRACTION  # noqa: F401
from gps_error_ros.model.effect_kinds import EFFECT_NAMES

#: Level of the whole diagnosis: the chance that it reports structure that is
#: not there (an effect, or something unexplained) is at most ALPHA.
ALPHA = 0.05
#: Tests in the first-round family, and at most in the retest of the extended model.
N_TESTS = 10
N_RETESTS = 5
#: The share of ALPHA the first round spends; the retest has the rest. Each
#: round is Holm at its share (Bonferroni over the two rounds, each test the
#: same share). At ALPHA each, an effect found and then a leftover each had
#: their own 5 %, and a walk with an effect got a false report in about 8 %.
FIRST_SHARE = N_TESTS / (N_TESTS + N_RETESTS)


def round_levels(alpha: float) -> tuple[float, float]:
    """Return the family-wise levels (first round, retest) of a diagnosis at ``alpha``."""
    return alpha * FIRST_SHARE, alpha * (1.0 - FIRST_SHARE)


#: Family-wise levels of the first round and of the retest at ALPHA.
FAMILY_ALPHA, RETEST_ALPHA = round_levels(ALPHA)
#: Largest motion lag searched, s; also the samples conditioned on per segment.
MAX_LAG_S = 5.0
#: Lags of the serial-correlation (portmanteau) tests.
SERIAL_LAGS = 30
#: Lags L (s) of the motion-dependence likelihood ratios.
MOTION_TEST_LAGS = (1, 2, 3, 4, 5)
#: Lags of the persistence tests of the squared innovations.
PERSIST_LAGS = 10
#: Smallest training and held-out parts, in samples on the 1 Hz grid: a
#: five-minute recording is diagnosed, with the wider intervals its size
#: gives (docs/decisions/0010-short-recordings.md).
MIN_TRAIN = 180
MIN_TEST = 80
#: Effects in schema order: the registry's (:mod:`gps_error_ros.model.effect_kinds`).
EFFECT_ORDER = EFFECT_NAMES
#: Cycle lengths (steps) the periodicity test looks at.
PERIODS = tuple(range(2, 31))
LOG2PI = math.log(2.0 * math.pi)


class DiagnosisError(ValueError):
    """A trace that cannot be diagnosed (too short, degenerate)."""


#: The AR orders (north, east) of a model.
Orders = Sequence[int]
