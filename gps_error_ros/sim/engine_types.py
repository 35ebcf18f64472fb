"""
What the fix engine counts, what it returns, and what it keeps per waiting step.

Split from :mod:`gps_error_ros.sim.engine` (which uses them all) to keep
that module about the engine's rules.
"""

from dataclasses import dataclass, field
from typing import Optional

import numpy as np


@dataclass
class EngineStats:
    """Counters an operator may want to see."""

    steps: int = 0
    fixes: int = 0
    skipped_no_truth: int = 0
    dropped_out_of_order: int = 0
    dropped_future: int = 0
    resets: int = 0
    pending_overflow: int = 0
    late_truth: int = 0      # times truth came for a step already skipped
    invalid_gaps: int = 0    # times steps were skipped while an agent's truth was invalid
    late_start: int = 0      # first clock more than max_pending steps after start_ns
    no_fix: int = 0          # steps resolved in an outage (profile availability)


@dataclass
class FixBatch:
    """The fixes of one output step: one row per agent in ``agents``."""

    stamp_ns: int
    agents: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    alt: np.ndarray
    error: np.ndarray = field(repr=False)
    fix: Optional[np.ndarray] = field(default=None, repr=False)   # False: no fix (an outage)
    velocity: Optional[np.ndarray] = field(default=None, repr=False)  # (m, 2) east/north m/s
    velocity_sd: Optional[np.ndarray] = field(default=None, repr=False)  # (m,) its error's SD, m/s
    # (m, 2) the velocity error's mean (speed bias)
    velocity_mean: Optional[np.ndarray] = field(default=None, repr=False)
    cov: Optional[np.ndarray] = field(default=None, repr=False)       # (m, 2, 2) north/east m^2
    accuracy: Optional[np.ndarray] = field(default=None, repr=False)  # (m,) stated 68 % radius, m
    # True: ``cov`` is each fix's own even where the node states one for all (a fault touched it)
    cov_per_fix: bool = field(default=False, repr=False)


@dataclass
class PendingStep:
    """An output step waiting for truth: its errors, and which agents are done."""

    t_ns: int             # the step's instant
    model_step: int       # the model step it carries
    err: np.ndarray       # (n, 2) north/east errors of every slot
    done: np.ndarray      # (n,) True once resolved (or free)
    fix: np.ndarray       # (n,) False in an outage (profile availability)
    side: dict[str, np.ndarray]   # name -> (n, d): the side streams' values (velocity, reported)
    cov: Optional[np.ndarray] = None       # (n, 2, 2) north/east covariance (conditional_cov)
