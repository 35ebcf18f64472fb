"""
What ``diagnose`` found, as records: the tests, the effects, what is left, the held-out measures.

A test of the family is an :class:`Outcome`; the diagnosis as a whole is
:class:`Findings`, which :class:`~.pipeline.Diagnosis` carries. Code reads
them by attribute. :meth:`Findings.to_dict` writes the JSON report, whose
keys are the fields' names.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Optional, Union

from gps_error_ros.diagnose.selection import Selection

#: A value of the JSON report (numbers, text, lists and mappings of them).
Json = Union[None, bool, int, float, str, Sequence['Json'], Mapping[str, 'Json']]


@dataclass(frozen=True)
class Outcome:
    """
    One test: its statistic and p-value, what it tests, and the family's decision.

    Attributes
    ----------
    statistic
        The test's statistic.
    p_value
        Its p-value, before any adjustment.
    test
        What the test is, in words.
    about
        The test's own figures (the lag or period where it peaked, the
        pairs it counted, ...), by name, as the report writes them.
    holm_adjusted_p, rejected
        Holm's adjusted p-value and decision in its family (None before).
    given
        Whether the rejection is a step already taken in another family.
    explained_by
        In the retest: the effects in the model that target what it tests.

    """

    statistic: float
    p_value: float
    test: str = ''
    about: dict[str, Json] = field(default_factory=dict)
    holm_adjusted_p: Optional[float] = None
    rejected: Optional[bool] = None
    given: bool = False
    explained_by: Optional[tuple[str, ...]] = None

    def decided(self, adjusted: float, rejected: bool, given: bool = False) -> Outcome:
        """Return this test with its family's decision."""
        return replace(self, holm_adjusted_p=adjusted, rejected=rejected, given=given)

    def whole(self, name: str) -> int:
        """Return the test's figure ``name``, an integer (a lag, a period, a count)."""
        value = self.about[name]
        if not isinstance(value, int):
            raise TypeError(f'{name}: expected an integer, got {value!r}')
        return value

    def word(self, name: str) -> str:
        """Return the test's figure ``name``, a word."""
        value = self.about[name]
        if not isinstance(value, str):
            raise TypeError(f'{name}: expected a word, got {value!r}')
        return value

    def wholes(self, name: str) -> list[int]:
        """Return the test's figure ``name``, a list of integers."""
        value = self.about[name]
        if not isinstance(value, list) or not all(isinstance(v, int) for v in value):
            raise TypeError(f'{name}: expected a list of integers, got {value!r}')
        return [int(v) for v in value]

    def picked(self) -> dict[str, Json]:
        """Return what an effect's evidence quotes of the test."""
        out: dict[str, Json] = {'statistic': self.statistic, 'p_value': self.p_value}
        if self.holm_adjusted_p is not None:
            out['holm_adjusted_p'] = self.holm_adjusted_p
        if 'at_lag_s' in self.about:
            out['at_lag_s'] = self.about['at_lag_s']
        return out

    def to_dict(self) -> dict[str, Json]:
        """Return the test as the report writes it."""
        out: dict[str, Json] = {'statistic': self.statistic, **self.about,
                                'p_value': self.p_value}
        if self.test:
            out['test'] = self.test
        if self.holm_adjusted_p is not None:
            out['holm_adjusted_p'] = self.holm_adjusted_p
            out['rejected'] = self.rejected
        if self.given:
            out['given'] = True
        if self.explained_by is not None:
            out['explained_by'] = list(self.explained_by)
        return out


def outcomes(tests: Mapping[str, Outcome]) -> dict[str, Json]:
    """Return tests by name as the report writes them."""
    return {k: t.to_dict() for k, t in tests.items()}


@dataclass(frozen=True)
class Left:
    """Structure a test found that no effect in the model explains (``unexplained``)."""

    structure: str
    stage: str                  # 'base model' or 'extended model'
    p_value: float
    holm_adjusted_p: float
    lags_largest: Optional[tuple[int, ...]] = None   # serial tests: their largest lags

    def to_dict(self) -> dict[str, Json]:
        """Return it as the report writes it."""
        out: dict[str, Json] = {'structure': self.structure, 'stage': self.stage}
        if self.lags_largest is not None:
            out['lags_largest'] = list(self.lags_largest)
        out.update(p_value=self.p_value, holm_adjusted_p=self.holm_adjusted_p)
        return out


@dataclass(frozen=True)
class Approximation:
    """Structure the retest found that an effect in the model targets: its form approximates."""

    structure: str
    effects: tuple[str, ...]
    holm_adjusted_p: float
    note: str = ('left by an effect already in the model: its fitted form approximates '
                 'the data-generating one')

    def to_dict(self) -> dict[str, Json]:
        """Return it as the report writes it."""
        return {'structure': self.structure, 'effects': list(self.effects),
                'holm_adjusted_p': self.holm_adjusted_p, 'note': self.note}


@dataclass(frozen=True)
class Alternative:
    """An effect that explains a rejected test too, turned down, and why."""

    effect: str
    reason: str
    bic: Mapping[str, float]

    def to_dict(self) -> dict[str, Json]:
        """Return it as the report writes it."""
        return {'effect': self.effect, 'reason': self.reason, 'bic': dict(self.bic)}


@dataclass(frozen=True)
class EffectFound:
    """An effect the tests found, with its evidence (the test, its figures, the BICs)."""

    name: str
    evidence: Mapping[str, Json]

    def to_dict(self) -> dict[str, Json]:
        """Return it as the report writes it."""
        return {'name': self.name, 'evidence': dict(self.evidence)}


@dataclass(frozen=True)
class ModelFound:
    """A model the diagnosis fitted: its AR orders, parameters and training BIC."""

    order: Mapping[str, int]            # by axis
    parameters: Mapping[str, Json]      # the profile's ``axes`` and ``effects``
    train_bic: float
    retest: Optional[Mapping[str, Outcome]] = None   # the extended model's second round

    def to_dict(self) -> dict[str, Json]:
        """Return it as the report writes it."""
        out: dict[str, Json] = {'order': dict(self.order), 'parameters': dict(self.parameters),
                                'train_bic': self.train_bic}
        if self.retest is not None:
            out['retest'] = outcomes(self.retest)
        return out


@dataclass(frozen=True)
class HeldOut:
    """A model on the held-out part: its NLL per sample, and its simulations' fidelity."""

    heldout_nll_per_sample: float
    fidelity: Mapping[str, Json]

    def to_dict(self) -> dict[str, Json]:
        """Return it as the report writes it."""
        return {'heldout_nll_per_sample': self.heldout_nll_per_sample, **self.fidelity}


@dataclass(frozen=True)
class Improvement:
    """The held-out NLL per sample the extended model gains, with its 95 % interval."""

    heldout_nll_per_sample: float
    ci95: tuple[float, float]
    method: str

    def to_dict(self) -> dict[str, Json]:
        """Return it as the report writes it."""
        return {'heldout_nll_per_sample': self.heldout_nll_per_sample,
                'ci95': list(self.ci95), 'method': self.method}


@dataclass(frozen=True)
class Findings:
    """
    Everything ``diagnose`` found (the report's fields; see ``docs/diagnose.md``).

    The split (``input`` .. ``cut_time_s``), how it tested (``alpha``,
    ``multiple_testing``, ``estimation``), the base model and its tests,
    the effects found and turned down, the selection, the extended model
    and its retest, what is left (``unexplained``, ``approximations``), the
    held-out measures before and after, and the gross failures left out.
    """

    input: str
    samples: int
    train_samples: int
    test_samples: int
    scored_test_samples: int
    split_rule: str
    cut_time_s: float
    alpha: float
    multiple_testing: str
    estimation: str
    base: ModelFound
    tests: Mapping[str, Outcome]
    effects: Sequence[EffectFound]
    alternatives_rejected: Sequence[Alternative]
    selection: Selection
    extended: ModelFound
    unexplained: Sequence[Left]
    approximations: Sequence[Approximation]
    error_before: HeldOut
    error_after: HeldOut
    improvement: Improvement
    gross_failures: Mapping[str, Json]

    @property
    def effect_names(self) -> list[str]:
        """Return the names of the effects found."""
        return [e.name for e in self.effects]

    def note(self) -> Optional[str]:
        """Return the remark under the held-out improvement, or None."""
        if not self.effects:
            return None
        if not self.selection.kept:
            return 'no effect kept: the extended model is the base model'
        lo, hi = self.improvement.ci95
        if lo <= 0.0 <= hi:
            return ('the 95 % interval of the improvement spans zero: the held-out '
                    'part does not show that the extended model predicts better')
        return None

    def to_dict(self) -> dict[str, Json]:
        """Return the findings as the JSON report writes them (before rounding)."""
        return {
            'input': self.input, 'samples': self.samples,
            'train_samples': self.train_samples, 'test_samples': self.test_samples,
            'scored_test_samples': self.scored_test_samples,
            'split': {'rule': self.split_rule, 'cut_time_s': self.cut_time_s},
            'alpha': self.alpha, 'multiple_testing': self.multiple_testing,
            'estimation': self.estimation, 'base': self.base.to_dict(),
            'tests': outcomes(self.tests),
            'effects': [e.to_dict() for e in self.effects],
            'alternatives_rejected': [a.to_dict() for a in self.alternatives_rejected],
            'selection': self.selection.to_dict(), 'extended': self.extended.to_dict(),
            'unexplained': [u.to_dict() for u in self.unexplained],
            'approximations': [a.to_dict() for a in self.approximations],
            'error_before': self.error_before.to_dict(),
            'error_after': self.error_after.to_dict(),
            'improvement': self.improvement.to_dict(),
            'gross_failures': dict(self.gross_failures)}
