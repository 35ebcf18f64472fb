"""
Smartphone GPS errors (Rostami et al.'s AR model, extended) for ROS 2 and simulators.

The Python API is the names of ``__all__`` (:mod:`gps_error_ros.api`):
load a profile, simulate errors for agents, add errors to a trajectory,
calibrate from recordings, validate a profile on a recording. They are loaded
on first use, so importing the package (as the nodes do) costs nothing.
"""

from typing import Any, TYPE_CHECKING

__version__ = "0.1.0"
__all__ = ['Errors', 'Fixes', 'Profile', 'add_errors', 'calibrate', 'load_profile',
           'simulate_errors', 'validate']

if TYPE_CHECKING:
    from gps_error_ros.api import (add_errors, calibrate, Errors, Fixes,  # noqa: F401
                                   load_profile, Profile, simulate_errors, validate)


def __getattr__(name: str) -> Any:
    """Return a name of the API, importing :mod:`gps_error_ros.api` on first use."""
    if name in __all__:
        from gps_error_ros import api
        return getattr(api, name)
    raise AttributeError(f'module {__name__!r} has no attribute {name!r}')
