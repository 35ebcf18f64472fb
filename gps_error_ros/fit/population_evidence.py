"""
What a population fit records of itself: the ``population`` entry of a profile's ``fit`` section.

:func:`~gps_error_ros.fit.population_fit.fit_population` and
:func:`~gps_error_ros.fit.population_bias.bias_section` write these records;
``calibrate``, the population's one-line summary and the evidence pages read
them. Each is a :class:`typing.TypedDict`: at run time the plain dict the
profile's YAML holds, to the type checker a record whose keys are declared
once, here, so the code that writes a key and the code that reads it cannot
drift apart unnoticed.
"""

from typing import TypedDict


class TimeConstant(TypedDict):
    """What the fit knows of the bias's time constant."""

    #: The time constant taken, s.
    value_s: float
    #: ``'estimate'``, or ``'upper bound'`` where the bias changes faster than a block.
    kind: str
    #: The neighbouring blocks' correlation as estimated, and its time constant, s.
    correlation_estimate: float
    estimate_s: float
    #: An approximate 95 % interval, s (``'inf'``: no upper end).
    interval_95_s: list[float | str]
    #: The block length, s: what the estimate resolves.
    resolution_s: float


class TwoScaleSpreads(TypedDict):
    """The spreads that tell a bias held for a run from one that wanders within it."""

    #: The SD of the runs' (chains of blocks') means, m per axis.
    run_means_sd_m: list[float]
    #: The pooled SD of the block means within a run, m per axis.
    block_means_within_run_sd_m: list[float]
    #: The wandering part's neighbouring-block correlation, as estimated.
    wander_correlation_estimate: float


class BetweenDays(TypedDict):
    """The allowance for other days added to a population of one occasion."""

    ratio: float
    held_sd_m: float
    source: str


class WithinModel(TypedDict):
    """The process within the blocks, where it is the extended model."""

    model: str
    effects: list[str]


class PopulationEvidence(TypedDict, total=False):
    """
    The population fit's record of itself.

    Always: ``block_s``, ``blocks``, ``within_order`` and ``fitted``; a fit
    refused has ``reason``; a fitted one the block spreads, the neighbour
    pairs and the draws; a bias on two time scales its wander and held
    parts too. ``calibrate`` adds ``occasions``, and a population of one
    occasion may carry ``between_days``; the extended model within, ``within``.
    """

    block_s: float
    blocks: int
    #: The order of the AR within blocks, per axis.
    within_order: dict[str, int]
    #: The blocks counted with each occasion's recordings once (where that differs).
    weighted_blocks: float
    fitted: bool
    #: Why no population was fitted.
    reason: str
    block_mean_sd_m: list[float]
    within_mean_sd_m: list[float]
    neighbour_pairs: int
    neighbour_correlation: float | None
    neighbour_correlation_estimate: float | None
    block_log_sd_sd: float
    #: One part: the bias SD as fitted, and the independent draws it rests on.
    bias_sd_estimate_m: list[float]
    independent_draws: float
    bias_time_constant: TimeConstant
    #: Two parts: the wandering and the held part as fitted, the contrasts within runs.
    wander_sd_estimate_m: list[float]
    wander_contrasts: float
    held_sd_estimate_m: list[float]
    run_means_sd_m: list[float]
    block_means_within_run_sd_m: list[float]
    wander_correlation_estimate: float
    #: The recordings' occasions (``calibrate``: recordings made together count once).
    occasions: int
    between_days: BetweenDays
    #: ``calibrate --population``: the extended model within, not the Gaussian AR.
    within: 'WithinModel'
