"""
Accuracy as a phone or a V2P message states it, from a 2x2 error covariance.

* :func:`ellipse`: the SAE J2735 positional-accuracy ellipse: semi-major and
  semi-minor axes at one standard deviation (m) and the major axis'
  orientation in degrees clockwise from true north, in [0, 180).
* :func:`radius68`: the radius (m) of the circle about the mean that holds
  68 % of the error, Android's ``Location.getAccuracy()``.

Both read the covariance they are given as a zero-mean error's: given the
mean square error matrix about the truth (``covariance_about`` truth, the
default of the node and ``simulate``), they describe the error about the
truth, bias included; given the covariance alone, the spread about the
error's mean. Covariances are north/east (m^2), arrays of shape (..., 2, 2).
"""

import numpy as np

from gps_error_ros.model.state import FloatArray, Numbers

_THETA = np.linspace(0.0, 2.0 * np.pi, 720, endpoint=False)


def ellipse(cov: Numbers) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Return (semi_major, semi_minor, orientation_deg) of north/east covariances."""
    cov = np.asarray(cov, dtype=float)
    nn, ee, ne = cov[..., 0, 0], cov[..., 1, 1], cov[..., 0, 1]
    half_sum, half_diff = 0.5 * (nn + ee), 0.5 * (nn - ee)
    root = np.hypot(half_diff, ne)
    major = np.sqrt(half_sum + root)
    minor = np.sqrt(np.maximum(half_sum - root, 0.0))
    # angle of the major axis from north towards east
    orientation = np.degrees(0.5 * np.arctan2(2.0 * ne, nn - ee)) % 180.0
    return major, minor, orientation


def _inside(a: FloatArray, major: FloatArray, minor: FloatArray) -> FloatArray:
    """Return P(|error| <= a) for zero-mean Gaussians with these principal SDs."""
    # in the principal axes: P = 1/(2 pi) * integral of (1 - exp(-a^2 g / 2)) / (sd1 sd2 g)
    c2, s2 = np.cos(_THETA) ** 2, np.sin(_THETA) ** 2
    g = c2 / major[..., None] ** 2 + s2 / minor[..., None] ** 2
    f = (1.0 - np.exp(-0.5 * a[..., None] ** 2 * g)) / (major[..., None] * minor[..., None] * g)
    return f.mean(axis=-1)


#: Radii already found, by (covariance, p): a crowd's covariances repeat at every step.
_KNOWN: dict[tuple[float, ...], float] = {}
_KNOWN_MAX = 4096


def radius68(cov: Numbers, p: float = 0.68) -> FloatArray:
    """
    Return the radius holding ``p`` of a zero-mean error with covariance ``cov``.

    Solved once per distinct covariance (a crowd in stationary mode has one
    for every agent and step): the distinct ones are found, those not met
    before are solved by bisection, and the answers are remembered.
    """
    cov = np.asarray(cov, dtype=float)
    flat = cov.reshape(-1, 4)
    if flat.shape[0] > 1 and (flat == flat[0]).all():      # one for all: no sort
        return np.full(cov.shape[:-2], radius68(flat[:1].reshape(2, 2), p))
    uniq, inverse = np.unique(flat, axis=0, return_inverse=True)
    keys = [(row.tobytes(), p) for row in uniq]
    radii = np.array([_KNOWN.get(k, np.nan) for k in keys])
    todo = np.flatnonzero(np.isnan(radii))
    if todo.size:
        radii[todo] = _bisect(uniq[todo].reshape(-1, 2, 2), p)
        if len(_KNOWN) + todo.size > _KNOWN_MAX:
            _KNOWN.clear()
        _KNOWN.update((keys[i], float(radii[i])) for i in todo)
    return radii[np.ravel(inverse)].reshape(cov.shape[:-2])


def _bisect(cov: FloatArray, p: float) -> FloatArray:
    """Return the radius holding ``p`` of each covariance (n, 2, 2), by bisection."""
    major, minor, _ = ellipse(cov)
    minor = np.maximum(minor, 1e-9 * np.maximum(major, 1e-12))
    lo, hi = np.zeros_like(major), 4.0 * np.maximum(major, 1e-12)
    for _ in range(60):                          # bisection: 4 major / 2^60
        mid = 0.5 * (lo + hi)
        below = _inside(mid, major, minor) < p
        lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
    return 0.5 * (lo + hi)
