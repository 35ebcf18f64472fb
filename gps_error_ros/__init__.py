"""
Smartphone GPS errors (Rostami et al.'s AR model, extended) for ROS 2 and simulators.

The Python API is nine names (:mod:`gps_error_ros.api`):

- ``load_profile(spec)``: a built-in profile (``DS5``, ``phone-suburban-drive``,
  ...) or a profile YAML, as a :class:`Profile`;
- ``simulate_errors(profile, agents, duration_s, seed)``: the errors of
  agents over time, as :class:`Errors`;
- ``add_errors(profile, t, seed, lat, lon)``: the fixes a phone would give
  along true positions, as :class:`Fixes`;
- ``calibrate(recordings)``: a profile fitted to recordings of one receiver;
- ``validate(profile, recording)``: how a recording compares with the
  profile's simulated traces;
- ``to_enu(lat, lon, datum)``: east and north metres about a datum, to
  compare fixes with the truth.

They are loaded on first use, so importing the package (as the nodes do)
costs nothing. ``help(gps_error_ros.add_errors)`` shows each one.
"""

from typing import Any as _Any, TYPE_CHECKING as _TYPE_CHECKING

__version__ = "0.1.0"
__all__ = ['Errors', 'Fixes', 'Profile', 'add_errors', 'calibrate', 'load_profile',
           'simulate_errors', 'to_enu', 'validate']

if _TYPE_CHECKING:
    from gps_error_ros.api import (add_errors, calibrate, Errors, Fixes,  # noqa: F401
                                   load_profile, Profile, simulate_errors, to_enu,
                                   validate)


def __getattr__(name: str) -> _Any:
    """Return a name of the API, importing :mod:`gps_error_ros.api` on first use."""
    if name in __all__:
        from gps_error_ros import api
        return getattr(api, name)
    raise AttributeError(f'module {__name__!r} has no attribute {name!r}')


def __dir__() -> list[str]:
    """Return the API's names (what tab-completion offers), with ``__version__``."""
    return sorted(__all__) + ['__version__']
