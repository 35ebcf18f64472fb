"""
Judging models on held-out data: how a simulator's traces compare with recordings it did not see.

Above the diagnosis (:mod:`gps_error_ros.diagnose`, which finds what the
AR model misses and fits the extended model): this room takes fitted
models and judges them as simulators. :mod:`.baselines` (the model classes
other simulators use), :mod:`.population_class` (a population profile as a
class), :mod:`.generalise` (folds across stretches, recordings and
receivers, grouped measures), :mod:`.consumers` and :mod:`.smoother` (what
a filter, a V2P warning and GTSAM conclude from the fixes),
:mod:`.beaten` and :mod:`.window_persistence` (where and why a class is
beaten), :mod:`.zoned_compare` (a profile per zone against one profile).
"""
