"""
What ``gps_error compare`` finds, named: the records of its JSON and the results that hold them.

The fold comparison (``compare --folds`` / ``--test``, and the evidence
pages' tools) writes one record per fold and class into JSON. Each record
below is a :class:`typing.TypedDict`: at run time the plain dict that is
written (so the JSON stays as ``docs/reference/cli.md`` documents it), to the
type checker a record whose keys are declared, so a renamed key fails the
check where it is read, not in a distant page.

A measure is named ``group:name`` (``scale:sd_north``); :func:`measure_key`,
:func:`group_of` and :func:`name_of` are the one place that builds and
reads such a name.

:class:`FoldComparison` and :class:`SplitComparison` are what the two kinds
of comparison return: ``summary()`` is the text the terminal shows,
``to_dict()`` the JSON document.
"""

from dataclasses import dataclass, field
from typing import Any, NotRequired, TypedDict

from gps_error_ros.fit.fidelity import Difference
from gps_error_ros.fit.envelope import Envelope
from gps_error_ros.fit.population_evidence import PopulationEvidence

#: What joins a measure's group and its name.
SEP = ':'


def measure_key(group: str, name: str) -> str:
    """Return the name of measure ``name`` of ``group`` (``'scale:sd_north'``)."""
    return f'{group}{SEP}{name}'


def group_of(key: str) -> str:
    """Return the group of a measure's name (``'scale'`` of ``'scale:sd_north'``)."""
    return key.split(SEP, 1)[0]


def name_of(key: str) -> str:
    """Return a measure's name without its group (``'sd_north'`` of ``'scale:sd_north'``)."""
    return key.split(SEP, 1)[1]


class ClassJudgement(TypedDict):
    """One class judged on one fold's held-out part."""

    #: The one-step predictive negative log density per held-out sample.
    heldout_nll_per_sample: float
    #: This class's NLL minus the population class's.
    nll_minus_population: Difference
    #: Each group's share of measures inside their simulated 95 % range.
    groups: dict[str, float]
    #: Each measure (``group:name``) against the simulated traces.
    measures: dict[str, Envelope]
    #: Each group's share inside for each simulated trace, judged as the real one.
    own_groups: dict[str, list[float]]
    #: A population class with nothing to pool over: the class it then is.
    same_as: NotRequired[str]
    #: The population classes: the fit's evidence and the written section.
    fit: NotRequired[PopulationEvidence]
    section: NotRequired[dict[str, Any] | None]
    #: The reference class: what its filter's error is made of.
    filter_parts: NotRequired[dict[str, Any]]
    #: The reference class: how its lag-1 ACF moves from block to block.
    persistence_spread: NotRequired[dict[str, Any] | None]
    #: The reference class: where better-scoring classes beat it (None: none do).
    where_beaten: NotRequired[dict[str, Any] | None]


class TrainingWindows(TypedDict):
    """The range of each error measure over the training part's windows like the held-out."""

    span_s: float
    windows: int
    #: {measure: [low, high]}; empty when no window qualifies.
    range: dict[str, list[float]]


class Fold(TypedDict):
    """One fold: its split, the training part's own measures, every class judged."""

    fold: str
    rule: str
    train_samples: int
    test_samples: int
    train_measures: dict[str, float]
    train_windows: TrainingWindows
    classes: dict[str, ClassJudgement]
    #: The speed and course group of the velocity section (None without one).
    velocity: dict[str, Any] | None


class NllAgainstPopulation(TypedDict):
    """A class's NLL minus the population class's, over the folds."""

    mean: float
    #: Folds on which the 95 % interval lies wholly below 0, or above.
    lower_folds: int
    higher_folds: int


class WorstGroup(TypedDict):
    """The group with the smallest mean share inside."""

    group: str
    inside_95: float


class OwnVerdict(TypedDict):
    """A class's worst group read against its own simulated traces' worst groups."""

    groups: list[str]
    worst: float
    own_worst_median: float
    #: The share of own sets of folds whose worst is at or below the real one's, %.
    percentile: float
    #: The share of own sets with every group at the bar or more, %.
    own_meet_bar: float


class ClassSummary(TypedDict):
    """One class over every fold."""

    heldout_nll_per_sample: float
    heldout_nll_per_fold: list[float]
    #: Folds on which the class scored the lowest NLL (ties count for each).
    best_score_folds: int
    nll_minus_population: NllAgainstPopulation
    groups: dict[str, float]
    worst_group: WorstGroup
    own: NotRequired[OwnVerdict]


@dataclass
class FoldComparison:
    """Every class judged on every fold, and each class over the folds."""

    #: One record per fold.
    folds: list[Fold]
    #: Each class over the folds (the JSON's ``summary``).
    classes: dict[str, ClassSummary]
    #: Simulated traces per class and fold, and the seed.
    sims: int
    seed: int
    #: Groups shown after the table's own (those some class has).
    groups: tuple[str, ...] = ()
    #: Lines that follow the table (where a class beat the population, ...).
    notes: list[str] = field(default_factory=list)

    def summary(self) -> str:
        """Return the table the terminal shows: one row per class, then the notes."""
        lines = [f'{len(self.folds)} fold(s): ' + '; '.join(
            f'{f["fold"]} ({f["train_samples"]} train / {f["test_samples"]} held out)'
            for f in self.folds)]
        lines.append(f'  {"class":13} {"NLL":>8} {"best":>5} {"- pop.":>7} {"<,>":>5} '
                     + ' '.join(f'{g[:11]:>11}' for g in self.groups))
        for name, c in self.classes.items():
            d = c['nll_minus_population']
            lines.append(
                f'  {name:13} {c["heldout_nll_per_sample"]:8.3f} {c["best_score_folds"]:5d} '
                f'{d["mean"]:+7.3f} {d["lower_folds"]:>2d},{d["higher_folds"]:<2d} '
                + ' '.join(f'{c["groups"][g]:11.2f}' if g in c['groups'] else f'{"-":>11}'
                           for g in self.groups))
        lines.append(
            '  (NLL: held-out NLL per sample, mean over folds; best: folds with the lowest; '
            '- pop.: NLL minus the population class\'s, mean over folds; <,>: folds on which '
            'it is lower, higher beyond its 95 % interval (paired samples, block bootstrap); '
            'groups: share of measures inside their simulated 95 % range, mean over folds)')
        return '\n'.join(lines + self.notes)

    def to_dict(self) -> dict[str, Any]:
        """Return the JSON document (``folds``, ``summary``, ``sims``, ``seed``)."""
        return {'folds': self.folds, 'summary': self.classes, 'sims': self.sims,
                'seed': self.seed}


class SplitClass(TypedDict):
    """One class on the single 70/30 split."""

    heldout_nll_per_sample: float
    #: Its NLL minus the lowest class's, paired on the held-out samples.
    nll_minus_best: Difference
    #: ``inside_95`` and ``measures`` against its simulated traces.
    fidelity: dict[str, Any]


@dataclass
class SplitComparison:
    """Every class fitted on one recording's first 70 % and judged on the rest."""

    input: str
    train_samples: int
    test_samples: int
    sims: int
    classes: dict[str, SplitClass]
    #: The gross failures found and left out (``gps_error calibrate``'s records).
    gross_failures: dict[str, dict[str, Any]] = field(default_factory=dict)
    #: One profile against a profile per zone (``--zones``), or None.
    zones: dict[str, Any] | None = None

    def summary(self) -> str:
        """Return the table the terminal shows: each class's held-out NLL and share inside."""
        lines = [f'{self.input}: {self.train_samples} train / {self.test_samples} held '
                 f'out; {self.sims} simulated traces per class',
                 f'  {"class":12} {"held-out NLL":>13} {"- lowest (95 % interval)":>28} '
                 f'{"inside_95":>10}']
        for name, c in self.classes.items():
            d = c['nll_minus_best']
            lines.append(f'  {name:12} {c["heldout_nll_per_sample"]:13.4f} {d["mean"]:9.4f} '
                         f'({d["ci95"][0]:7.4f} .. {d["ci95"][1]:7.4f}) '
                         f'{c["fidelity"]["inside_95"]:10.2f}')
        lines.append('  (- lowest: the NLL minus the lowest class\'s, paired on the held-out '
                     'samples; an interval that holds 0 cannot tell the two apart)')
        return '\n'.join(lines)

    def to_dict(self) -> dict[str, Any]:
        """Return the JSON document ``compare --json`` writes."""
        doc: dict[str, Any] = {'input': self.input, 'train_samples': self.train_samples,
                               'test_samples': self.test_samples, 'classes': self.classes,
                               'gross_failures': self.gross_failures}
        if self.zones is not None:
            doc['zones'] = self.zones
        return doc
