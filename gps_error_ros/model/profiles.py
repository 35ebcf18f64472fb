"""
Error-model profiles: the YAML schema (version 1), loading and lookup.

A profile names a data set and carries its AR fit per axis::

    schema: 1
    name: DS5
    description: 7th Avenue, Manhattan; Google Pixel (1st generation)
    source: Rostami et al., ..., Table II
    rate_hz: 1.0
    axes:
      north: {delta: 0.07, phi: [1.18, -0.06, -0.14], sigma_w: 1.52}
      east:  {delta: -0.02, phi: [1.15, -0.03, -0.14], sigma_w: 1.58}

Optional keys: ``vertical_sd`` (metres, the altitude standard deviation
reported in the fix covariance), ``notes`` (free text), ``fit`` (how the
profile was calibrated) and ``effects`` (model extensions written by
``gps_error diagnose --profile-out``; schema in :mod:`effects`; a profile
without them behaves exactly as the paper's model) and ``availability``
(fix outages, :mod:`availability`; without it every step has a fix) and
``velocity`` (reported speed and course, :mod:`velocity`) and
``reported_accuracy`` (the accuracy the phone states, :mod:`reported`) and
``gross_failures`` (fixes that failed, :mod:`failures`) and ``population``
(each agent's own bias and scale, :mod:`population`). A profile without
``axes`` is a placeholder for a data set with no published fit; it loads, but
:meth:`Profile.model` refuses it. Any other key is an error.
"""

import copy
from dataclasses import dataclass, field
import math
import os
from pathlib import Path
import re
from typing import Any, Callable, NoReturn, Optional

import yaml

from gps_error_ros.model.about_truth import AboutTruth
from gps_error_ros.model.ar_model import AxisParams, AXES, ModelError
from gps_error_ros.model.atomic import atomic_output
from gps_error_ros.model.availability import (Availability, availability_from_dict,
                                              AvailabilityError, WithAvailability)
from gps_error_ros.model.effects import build_model, Effects, effects_from_dict, EffectsError
from gps_error_ros.model.failures import (failures_from_dict, FailuresError,
                                          GrossFailureProcess, WithFailures)
from gps_error_ros.model.population import (Population, population_from_dict, PopulationError,
                                            WithPopulation)
from gps_error_ros.model.protocol import opaque, OpaqueModel, OpaqueProcess
from gps_error_ros.model.reported import ReportedAccuracy, reported_from_dict, ReportedError
from gps_error_ros.model.section_spec import Field, SectionSpec
from gps_error_ros.model.velocity import Velocity, velocity_from_dict, VelocityError

SCHEMA_VERSION = 1
PACKAGE = 'gps_error_ros'
PROFILE_SUBDIR = ('config', 'profiles')

_TOP_REQUIRED = ('schema', 'name', 'description', 'source', 'rate_hz')
_TOP_OPTIONAL = ('axes', 'vertical_sd', 'notes', 'fit', 'effects', 'availability',
                 'velocity', 'reported_accuracy', 'gross_failures', 'population')
_NAME_RE = re.compile(r'^ds[1-9][0-9]*$', re.IGNORECASE)


class ProfileError(ValueError):
    """A profile that is missing, unreadable or does not match the schema."""


class ProfileNotFittedError(ProfileError):
    """A placeholder profile (no published fit) was selected for simulation."""


@dataclass(frozen=True)
class Profile:
    """
    A loaded, validated profile: the AR process per axis and its sections.

    ``axes`` holds each axis' AR parameters (``north``, ``east``), ``effects``
    the extended model's effects; the optional sections (``availability``,
    ``velocity``, ``reported_accuracy``, ``gross_failures``, ``population``)
    are None where the profile has none. ``save(path)`` writes it as YAML.

    Examples
    --------
    >>> from gps_error_ros import load_profile
    >>> ds5 = load_profile('DS5')
    >>> ds5.rate_hz, ds5.axes['north'].order, list(ds5.axes)
    (1.0, 3, ['north', 'east'])
    >>> ds5.axes['north'].phi                  # the paper's Table II, DS5's north
    (1.18, -0.06, -0.14)
    >>> ds5.population is None, ds5.effects.names
    (True, ())

    """

    name: str
    description: str
    source: str
    rate_hz: float
    axes: Optional[dict[str, AxisParams]] = None
    vertical_sd: Optional[float] = None
    notes: str = ''
    fit: dict[str, Any] = field(default_factory=dict)
    effects: Effects = field(default_factory=Effects)
    path: str = ''
    availability: Optional[Availability] = None
    velocity: Optional[Velocity] = None
    reported_accuracy: Optional[ReportedAccuracy] = None
    gross_failures: Optional[GrossFailureProcess] = None
    population: Optional[Population] = None
    #: the mapping it was read from (what :meth:`to_dict` returns)
    raw: dict[str, Any] = field(default_factory=dict, compare=False, repr=False)

    def to_dict(self) -> dict[str, Any]:
        """Return the profile as the plain mapping a profile YAML holds."""
        return copy.deepcopy(self.raw)

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write the profile to ``path`` as YAML, for the node and the commands."""
        if not self.raw:
            raise ProfileError(f'profile {self.name}: built without its mapping, nothing to '
                               f'write; load it with load_profile or profile_from_dict')
        write_profile(path, self.to_dict(), 'the Python API')

    @property
    def fitted(self) -> bool:
        """Return True when the profile carries AR parameters."""
        return self.axes is not None

    def process(self) -> OpaqueProcess:
        """
        Return the profile's error process alone: the AR part and its effects.

        Returns
        -------
        OpaqueProcess
            The process, without population, failures or availability: an
            :class:`~.ar_model.ARErrorModel` or, with effects, an
            :class:`~.effects.ExtendedModel`.

        Raises
        ------
        ProfileNotFittedError
            For a placeholder profile.

        """
        if self.axes is None:
            fitted = [p.name for p in (load_profile(n) for n in builtin_names())
                      if p.fitted]
            raise ProfileNotFittedError(
                f'profile {self.name} ({self.path}) has no published fit: '
                f'the reference paper gives AR parameters only for '
                f'{", ".join(fitted)}. Select one of those, or calibrate a '
                f'profile from a recording of your own (`gps_error calibrate '
                f'TRACE.csv -o PROFILE.yaml`) and pass its path')
        try:
            return build_model(self.axes['north'], self.axes['east'], self.effects)
        except ModelError as exc:
            raise ProfileError(f'{self.path}: {exc}') from None

    def model(self, gross_failures: bool = True, about_truth: bool = False,
              process: Optional[OpaqueModel] = None) -> OpaqueModel:
        """
        Return the error model of this profile.

        With its effects, the agent's population draw (``population``), gross
        failures (unless ``gross_failures`` is False) and availability, each
        wrapped around the one before. ``about_truth``:
        its stated covariances are the error's mean square about the truth
        (:mod:`about_truth`), not its covariance about its mean.

        Parameters
        ----------
        gross_failures
            Include the ``gross_failures`` section, if the profile has one.
        about_truth
            State covariances about the truth (see above).
        process
            The error process to wrap in place of the profile's own
            (:meth:`process`): a zone map's (:class:`~.zoned.WithZones`).

        Returns
        -------
        OpaqueModel
            The model to simulate or serve with: an :class:`ARErrorModel` or
            :class:`~.effects.ExtendedModel`, wrapped as the profile says (its
            state class is known at run time, :func:`~.protocol.opaque`).

        Raises
        ------
        ProfileNotFittedError
            For a placeholder profile.

        """
        model: OpaqueModel = self.process() if process is None else process
        if self.population is not None:
            model = opaque(WithPopulation(model, self.population, self.rate_hz))
        if about_truth:
            model = opaque(AboutTruth(model))
        if gross_failures and self.gross_failures is not None:
            model = opaque(WithFailures(model, self.gross_failures))
        if self.availability is not None:
            model = opaque(WithAvailability(model, self.availability))
        return model

    def vertical_variance(self, model: Optional[OpaqueModel] = None) -> float:
        """
        Return the altitude variance (m^2) reported in fixes.

        The paper has no vertical model, so the published altitude is the
        truth's. A profile may set ``vertical_sd``; otherwise it is twice the
        larger horizontal stationary standard deviation, so that consumers
        do not trust the altitude more than the horizontal position.
        """
        if self.vertical_sd is not None:
            return self.vertical_sd ** 2
        model = model or self.model()
        return (2.0 * float(max(model.stationary_sd))) ** 2


def _fail(source: str, key: str, expected: str, got: Any) -> NoReturn:
    raise ProfileError(f'{source}: key {key!r}: expected {expected}, got {got!r}')


def _number(source: str, key: str, value: Any, positive: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        _fail(source, key, 'a number', value)
    if not math.isfinite(value):
        _fail(source, key, 'a finite number', value)
    if positive and not value > 0:
        _fail(source, key, 'a number > 0', value)
    return float(value)


def _text(source: str, key: str, value: Any) -> str:
    if not isinstance(value, str):
        _fail(source, key, 'a string', value)
    return value


#: Each axis of ``axes`` (north, then east), field by field; the order and stationarity
#: of ``phi`` are :class:`~.ar_model.AxisParams`'s rules.
AXIS_FIELDS = (
    Field('delta', 'the constant of the recursion (m); the mean error is '
          '`delta / (1 - sum(phi))`', lo=-math.inf, hi=math.inf, lo_open=True, hi_open=True,
          digits=6),
    Field('phi', 'the AR coefficients, lag 1 first; their number is the order, 1 to 16, '
          'and the process must be stationary', kind='numbers', lo=-math.inf, hi=math.inf,
          lo_open=True, hi_open=True, digits=6),
    Field('sigma_w', 'the innovations\' standard deviation (m)', lo=1e-6, hi=1e6, digits=6))
#: ``axes.north`` and ``axes.east``, each declared by :data:`AXIS_FIELDS`.
AXIS_SECTIONS = {ax: SectionSpec(f'axes.{ax}', AXIS_FIELDS, ProfileError) for ax in AXES}


def _axis(source: str, name: str, raw: Any) -> AxisParams:
    """Return one axis of ``axes``, checked as :data:`AXIS_SECTIONS` declares it."""
    v = AXIS_SECTIONS[name].read(raw, source)
    try:
        return AxisParams(v['delta'], v['phi'], v['sigma_w'])
    except ModelError as exc:
        raise ProfileError(f'{source}: key {"axes." + name!r}: {exc}') from None


#: The optional sections with readers of their own, in schema order: key, reader.
_SECTIONS: tuple[tuple[str, Callable[[Any, str], Any]], ...] = (
    ('availability', availability_from_dict), ('velocity', velocity_from_dict),
    ('reported_accuracy', reported_from_dict), ('gross_failures', failures_from_dict),
    ('population', population_from_dict))


def _section(raw: dict[str, Any], key: str, parse: Callable[[Any, str], Any],
             source: str) -> Any:
    """Return an optional section parsed by ``parse``, or None; its error as ProfileError."""
    if raw.get(key) is None:
        return None
    try:
        return parse(raw[key], source)
    except (AvailabilityError, VelocityError, ReportedError, FailuresError,
            PopulationError) as exc:
        raise ProfileError(str(exc)) from None


def profile_from_dict(raw: Any, source: str = '<profile>') -> Profile:
    """Validate a parsed profile mapping and return a :class:`Profile`."""
    if not isinstance(raw, dict):
        raise ProfileError(f'{source}: expected a YAML mapping at the top level, '
                           f'got {type(raw).__name__}')
    unknown = sorted(set(raw) - set(_TOP_REQUIRED) - set(_TOP_OPTIONAL))
    if unknown:
        _fail(source, unknown[0],
              f'one of {list(_TOP_REQUIRED + _TOP_OPTIONAL)}', unknown[0])
    for k in _TOP_REQUIRED:
        if k not in raw:
            raise ProfileError(f'{source}: key {k!r} is missing '
                               f'(required: {list(_TOP_REQUIRED)})')
    if raw['schema'] != SCHEMA_VERSION or isinstance(raw['schema'], bool):
        _fail(source, 'schema', f'{SCHEMA_VERSION}', raw['schema'])
    name = _text(source, 'name', raw['name'])
    if not name:
        _fail(source, 'name', 'a non-empty string', name)
    axes = None
    if raw.get('axes') is not None:
        a = raw['axes']
        if not isinstance(a, dict) or sorted(a) != sorted(AXES):
            _fail(source, 'axes', f'a mapping with exactly {list(AXES)}', a)
        axes = {n: _axis(source, n, a[n]) for n in AXES}
    vertical = raw.get('vertical_sd')
    if vertical is not None:
        vertical = _number(source, 'vertical_sd', vertical, positive=True)
    for k in ('fit', 'effects'):
        if raw.get(k) is not None and not isinstance(raw[k], dict):
            _fail(source, k, 'a mapping', raw[k])
    try:
        effects = effects_from_dict(raw.get('effects') or {}, source)
    except EffectsError as exc:
        raise ProfileError(str(exc)) from None
    sections = {key: _section(raw, key, read, source) for key, read in _SECTIONS}
    if effects.names and axes is None:
        _fail(source, 'effects', 'no effects in a profile without axes',
              raw['effects'])
    return Profile(
        name=name,
        description=_text(source, 'description', raw['description']),
        source=_text(source, 'source', raw['source']),
        rate_hz=_number(source, 'rate_hz', raw['rate_hz'], positive=True),
        axes=axes,
        vertical_sd=vertical,
        notes=_text(source, 'notes', raw.get('notes') or ''),
        fit=dict(raw.get('fit') or {}),
        effects=effects,
        path=source,
        raw=copy.deepcopy(raw),
        **sections)


def load_profile_file(path: str | os.PathLike[str]) -> Profile:
    """Load and validate the profile YAML at ``path``."""
    path = Path(path)
    try:
        text = path.read_text(encoding='utf-8')
    except FileNotFoundError:
        raise ProfileError(f'{path}: profile file not found') from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ProfileError(f'{path}: cannot read profile file: {exc}') from None
    try:
        raw = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ProfileError(f'{path}: malformed YAML: {exc}') from None
    return profile_from_dict(raw, str(path))


def profile_dirs() -> list[Path]:
    """
    Return the directories searched for built-in profiles, in order.

    1. ``config/profiles`` beside the package source (editable installs and
       running from a checkout);
    2. ``share/gps_error_ros/config/profiles`` under each prefix in
       ``AMENT_PREFIX_PATH`` that has the package in its ament index (colcon
       and ROS installs);
    3. ``share/gps_error_ros/config/profiles`` under the prefix the package
       is installed in (``pip install .`` into a venv or ``--prefix``).
    """
    package = Path(__file__).resolve().parent.parent     # gps_error_ros/
    dirs = [package.parent.joinpath(*PROFILE_SUBDIR)]
    for prefix in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep):
        if prefix and Path(prefix, 'share', 'ament_index', 'resource_index',
                           'packages', PACKAGE).exists():
            dirs.append(Path(prefix, 'share', PACKAGE, *PROFILE_SUBDIR))
    # <prefix>/lib/pythonX.Y/site-packages/gps_error_ros
    if len(package.parents) >= 4:
        dirs.append(package.parents[3].joinpath('share', PACKAGE, *PROFILE_SUBDIR))
    return [d for d in dict.fromkeys(dirs)]


def builtin_dir() -> Path:
    """Return the first existing built-in profile directory."""
    for d in profile_dirs():
        if d.is_dir() and any(d.glob('*.yaml')):
            return d
    raise ProfileError(
        'the built-in profiles were not found; searched: '
        + ', '.join(str(d) for d in profile_dirs()))


def builtin_names() -> list[str]:
    """Return the names of the built-in profiles (DS1..DS7, then the receivers')."""
    return sorted((p.stem for p in builtin_dir().glob('*.yaml')),
                  key=lambda s: (len(s), s))


def _choices() -> str:
    """Return the built-in names for messages: the fitted ones, then the rest."""
    names = builtin_names()
    fitted = [n for n in names if load_profile_file(builtin_dir() / f'{n}.yaml').fitted]
    rest = [n for n in names if n not in fitted]
    return (', '.join(fitted) + (f' (or {", ".join(rest)}, which have no published '
                                 f'fit)' if rest else ''))


def load_profile(spec: str | os.PathLike[str]) -> Profile:
    """Load a profile by built-in name (case-insensitive) or by file path."""
    spec = str(spec).strip()
    named = {n.lower(): n for n in builtin_names()}
    if spec.lower() in named and not _NAME_RE.match(spec) and not Path(spec).exists():
        return load_profile_file(builtin_dir() / f'{named[spec.lower()]}.yaml')
    if _NAME_RE.match(spec):
        path = builtin_dir() / f'{spec.upper()}.yaml'
        if not path.exists():
            raise ProfileError(
                f'unknown profile {spec!r}: expected one of {_choices()} or the '
                f'path of a profile YAML')
        return load_profile_file(path)
    path = Path(spec).expanduser()
    if path.suffix.lower() not in ('.yaml', '.yml') and not path.exists():
        raise ProfileError(
            f'unknown profile {spec!r}: expected one of {_choices()} or the '
            f'path of a profile YAML')
    return load_profile_file(path)


def axes_mapping(north: AxisParams, east: AxisParams) -> dict[str, dict[str, Any]]:
    """Return the ``axes`` section of two :class:`AxisParams`, rounded as declared."""
    return {ax: AXIS_SECTIONS[ax].write({'delta': p.delta, 'phi': p.phi, 'sigma_w': p.sigma_w})
            for ax, p in zip(AXES, (north, east))}


def profile_mapping(name: str, description: str, source: str, axes: Any, rate_hz: float = 1.0,
                    effects: Any = None, fit: Optional[dict[str, Any]] = None,
                    availability: Any = None, velocity: Any = None,
                    reported_accuracy: Any = None, gross_failures: Any = None,
                    population: Any = None) -> dict[str, Any]:
    """
    Return a profile as plain data (schema :data:`SCHEMA_VERSION`).

    ``axes`` is a pair of :class:`AxisParams` (north, east) or an ``axes``
    mapping; each section is its object (:class:`Effects`, :class:`Velocity`,
    ...) or its mapping. Keys come in schema order, as :func:`write_profile`
    writes them.
    """
    if not isinstance(axes, dict):
        axes = axes_mapping(*axes)
    prof = {'schema': SCHEMA_VERSION, 'name': name, 'description': description,
            'source': source, 'rate_hz': float(rate_hz), 'axes': axes}
    for key, section in (('effects', effects), ('availability', availability),
                         ('velocity', velocity), ('reported_accuracy', reported_accuracy),
                         ('gross_failures', gross_failures), ('population', population)):
        plain = section.to_dict() if hasattr(section, 'to_dict') else section
        if plain:
            prof[key] = plain
    if fit is not None:
        prof['fit'] = fit
    return prof


def write_profile(path: str | os.PathLike[str], profile: dict[str, Any],
                  tool: str = 'calibrate') -> None:
    """
    Write a profile mapping as YAML (keys in schema order).

    Written beside ``path`` and renamed when complete, so that a failure
    never leaves a truncated profile behind.
    """
    with atomic_output(path) as tmp:
        with open(tmp, 'w', encoding='utf-8') as f:
            f.write(f'# Written by gps_error {tool}.\n')
            yaml.safe_dump(profile, f, sort_keys=False, default_flow_style=None,
                           width=100)
