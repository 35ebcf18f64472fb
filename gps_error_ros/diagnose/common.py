"""
What every step of the diagnosis shares: its constants and its error.

One place, so that the steps (split, mean, laws, family, fidelity,
baselines, pipeline) import these and not each other's internals.
"""

import math

#: Fraction of a trace's time span that trains; the rest is held out.
TRAIN_FRACTION = 0.7
#: Family-wise level of the test family (Holm).
ALPHA = 0.05
#: Largest motion lag searched, s; also the samples conditioned on per segment.
MAX_LAG_S = 5.0
#: Lags of the serial-correlation (portmanteau) tests.
SERIAL_LAGS = 30
#: Lags L (s) of the motion-dependence likelihood ratios.
MOTION_TEST_LAGS = (1, 2, 3, 4, 5)
#: Tests in the first-round family.
N_TESTS = 10
#: Lags of the persistence tests of the squared innovations.
PERSIST_LAGS = 10
#: Smallest training and held-out parts, in samples on the 1 Hz grid.
MIN_TRAIN = 300
MIN_TEST = 100
#: Largest lag of the fidelity autocorrelation measures, s.
FIDELITY_MAX_LAG = 30
#: Effects in schema order (as ``gps_error_ros.model.effects.EFFECT_NAMES``).
EFFECT_ORDER = ('cross_axis_coupling', 'motion_lag', 'heavy_tails',
                'variance_regimes', 'street_frame', 'periodic', 'outliers')
#: Cycle lengths (steps) the periodicity test looks at.
PERIODS = tuple(range(2, 31))
LOG2PI = math.log(2.0 * math.pi)


class DiagnosisError(ValueError):
    """A trace that cannot be diagnosed (too short, degenerate)."""
