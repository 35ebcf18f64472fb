"""
The compiled loops of :mod:`.kernels` (numba, the optional extra ``fast``), when present.

The diagnosis has recursions that cannot be vectorised over time (the jump
filter, the variance regimes' filter). Each has a numpy form and, in
:mod:`.kernels`, the same loop for numba to compile; :func:`kernel` says
which to run (decision record 0008).
"""

from typing import Any

#: Whether the compiled loops run when numba is installed (tests turn it off to
#: compare the two forms).
COMPILED = True
_LOADED: dict[str, object] = {}


def kernel(name: str) -> Any:
    """
    Return the compiled function ``name`` of :mod:`.kernels`, or None.

    None when numba is not installed (or finds no place for its cache) or
    :data:`COMPILED` is off; the caller then runs the numpy form of the same
    loop.
    """
    if not COMPILED:
        return None
    if 'kernels' not in _LOADED:
        loaded: object = None
        try:
            from gps_error_ros.diagnose import kernels as loaded
        except (ImportError, RuntimeError):
            pass            # no numba, or (RuntimeError) nowhere to write its cache: numpy
        _LOADED['kernels'] = loaded
    return None if _LOADED['kernels'] is None else getattr(_LOADED['kernels'], name)
