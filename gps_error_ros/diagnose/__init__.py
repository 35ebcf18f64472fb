"""
The diagnosis: what the AR model misses in a trace, and the extended model.

The steps, one module each: :mod:`.split` (train/held-out), :mod:`.mean`
(AR and motion terms), :mod:`.laws` (innovation laws, EM, forward filter),
:mod:`.models` (a fitted model), :mod:`.family` (the test family, Holm),
:mod:`.fidelity` (simulated against held-out), and :mod:`.pipeline`, which
runs them in order. Judging fitted models as simulators on held-out data
(the classes, the folds, the consumers) is the room above,
:mod:`gps_error_ros.judge`.
"""

from gps_error_ros.diagnose.common import ALPHA, DiagnosisError
from gps_error_ros.diagnose.pipeline import Diagnosis, diagnose, extended_profile

__all__ = ['ALPHA', 'Diagnosis', 'diagnose', 'DiagnosisError', 'extended_profile']
