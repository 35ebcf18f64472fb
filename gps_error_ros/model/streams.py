"""
Counter-based random streams: noise as a pure function of (key, domain, index).

Every random number the error model uses is addressed by an agent key, a
domain (what the number is for) and an index (the model step, or a slot of the
initial state). Nothing depends on how many agents are drawn together, in which
order, or in which process, so a crowd can be split over processes and an
agent's errors stay the same. All functions are vectorised over agents.

Generator: SplitMix64 (Steele, Lea and Flood 2014), evaluated at arbitrary
positions of its Weyl sequence ``key + position * GAMMA``. Each 64-bit output
is split into two 32-bit uniforms on the open interval (0, 1), and the
Box-Muller transform turns them into two independent standard normals, which
is why draws come in pairs (north, east). With 32-bit uniforms the largest
normal that can appear is about 6.66 (probability of exceeding it in a true
normal: 3e-11 per draw). The transform runs in single precision, where numpy
has vectorised log/sin/cos (a relative error of about 1e-7, micrometres on
metre-sized errors), and in cache-sized chunks; this roughly triples the
throughput. Results are bit-identical on one machine type; CPUs whose numpy
picks another SIMD path may differ in the last float32 bits.
"""

import hashlib
from typing import Any, Iterable

import numpy as np
import numpy.typing as npt

_GAMMA = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_S30 = np.uint64(30)
_S27 = np.uint64(27)
_S31 = np.uint64(31)
_S32 = np.uint64(32)
_LOW32 = np.uint64(0xFFFFFFFF)
_INV32 = 1.0 / 4294967296.0

#: Bits of the position that hold the counter; the domain sits above them.
COUNTER_BITS = 48

# --- the registry of stream domains ------------------------------------------
# Every kind of draw has a domain of its own, so no two draws ever share a
# random word. Within a domain the position is the model step, except for the
# initial state, whose pairs sit at ``step * INIT_SLOTS + slot``
# (:func:`init_position`). A new effect that draws adds its domain here.

#: Innovations: one normal pair (north, east) per model step.
DOMAIN_STEP = 0
#: Initial AR state drawn at a model step: ``INIT_SLOTS`` normal pairs.
DOMAIN_INIT = 1
#: Variance regimes: the transition's uniform, one per model step.
DOMAIN_REGIME = 2
#: Heavy tails: the Student-t mixing variable's uniform, one per model step.
DOMAIN_TAIL = 3
#: Variance regimes: the initial regime's uniform, one per start step.
DOMAIN_INIT_REGIME = 4

#: Availability: the outage start's and length's uniforms, one pair per model step.
DOMAIN_OUTAGE = 5
#: Availability: the initial outage state's uniforms, one pair per start step.
DOMAIN_INIT_OUTAGE = 6

#: Velocity: the east/north normal pair of the velocity error, one per model step.
DOMAIN_VELOCITY = 7
#: Velocity: the initial velocity error's normal pair, one per start step.
DOMAIN_INIT_VELOCITY = 8

#: Reported accuracy: the normal pair (first used) of the radius's fluctuation, per model step.
DOMAIN_REPORTED = 9
#: Reported accuracy: the initial fluctuation's normal pair, one per start step.
DOMAIN_INIT_REPORTED = 10

#: Periodic effect: the agent's phase in the cycle, one uniform at position 0.
DOMAIN_PERIODIC = 11

#: Outliers: the jump's start-or-end uniform, one per model step.
DOMAIN_OUTLIER = 12
#: Outliers: a starting jump's offset, one normal pair per model step.
DOMAIN_OUTLIER_JUMP = 13
#: Outliers: whether the initial state is in a jump, one uniform per start step.
DOMAIN_INIT_OUTLIER = 14
#: Outliers: the initial jump's offset, one normal pair per start step.
DOMAIN_INIT_OUTLIER_JUMP = 15

#: Gross failures: whether the fix failed and its size, one uniform pair per model step.
DOMAIN_FAILURE = 16
#: Gross failures: a failed fix's direction, one uniform per model step.
DOMAIN_FAILURE_DIRECTION = 17

#: Population: the agent's scale, one normal pair (first used) at position 0.
DOMAIN_POPULATION_SCALE = 18
#: Population: the run's initial bias, one normal pair per start step.
DOMAIN_INIT_BIAS = 19
#: Population: the bias's wander, one normal pair per model step.
DOMAIN_BIAS = 20
#: Population: a Student-t bias's chi-square, pairs 0.. at ``init_position(start, slot)``.
DOMAIN_BIAS_MIX = 21

#: Gross failures: the agent's own rate, one normal pair (first used) at position 0.
DOMAIN_FAILURE_RATE = 22
#: Population: the part of the run's bias held for the run, one normal pair per start step.
DOMAIN_RUN_BIAS = 23

#: Velocity: the agent's scale of its velocity error, one normal pair (first used) at position 0.
DOMAIN_VELOCITY_SCALE = 24

#: Velocity: whether the step's innovation bursts, one uniform pair (first used) per model step.
DOMAIN_VELOCITY_BURST = 25
#: Velocity: whether the initial error bursts, one uniform pair (first used) per start step.
DOMAIN_INIT_VELOCITY_BURST = 26

#: Normal pairs reserved per initial state: the largest AR order that fits.
INIT_SLOTS = 16

DOMAINS = {
    'step': DOMAIN_STEP, 'init': DOMAIN_INIT, 'regime': DOMAIN_REGIME,
    'tail': DOMAIN_TAIL, 'init_regime': DOMAIN_INIT_REGIME,
    'outage': DOMAIN_OUTAGE, 'init_outage': DOMAIN_INIT_OUTAGE,
    'velocity': DOMAIN_VELOCITY, 'init_velocity': DOMAIN_INIT_VELOCITY,
    'reported': DOMAIN_REPORTED, 'init_reported': DOMAIN_INIT_REPORTED,
    'periodic': DOMAIN_PERIODIC, 'outlier': DOMAIN_OUTLIER,
    'outlier_jump': DOMAIN_OUTLIER_JUMP, 'init_outlier': DOMAIN_INIT_OUTLIER,
    'init_outlier_jump': DOMAIN_INIT_OUTLIER_JUMP,
    'failure': DOMAIN_FAILURE, 'failure_direction': DOMAIN_FAILURE_DIRECTION,
    'population_scale': DOMAIN_POPULATION_SCALE, 'init_bias': DOMAIN_INIT_BIAS,
    'bias': DOMAIN_BIAS, 'bias_mix': DOMAIN_BIAS_MIX,
    'failure_rate': DOMAIN_FAILURE_RATE, 'run_bias': DOMAIN_RUN_BIAS,
    'velocity_scale': DOMAIN_VELOCITY_SCALE, 'velocity_burst': DOMAIN_VELOCITY_BURST,
    'init_velocity_burst': DOMAIN_INIT_VELOCITY_BURST,
}


def init_position(index: int, slot: int) -> int:
    """
    Return the position in ``DOMAIN_INIT`` of pair ``slot`` of step ``index``.

    Parameters
    ----------
    index
        The model step at which the initial state is drawn.
    slot
        The pair within it, in [0, INIT_SLOTS).

    Returns
    -------
    int
        ``index * INIT_SLOTS + slot``.

    Raises
    ------
    ValueError
        When ``slot`` is outside [0, INIT_SLOTS): it would share a word with
        the next step's initial state.

    """
    if not 0 <= slot < INIT_SLOTS:
        raise ValueError(f'initial-state slot must be in [0, {INIT_SLOTS}), '
                         f'got {slot} (an AR order above {INIT_SLOTS})')
    return index * INIT_SLOTS + slot


def agent_key(seed: int | np.integer[Any], name: str = '') -> np.uint64:
    """
    Return the 64-bit stream key of an agent.

    Parameters
    ----------
    seed
        The run's seed, a non-negative integer below 2**64.
    name
        The agent's name ('' for a single-agent node).

    Returns
    -------
    numpy.uint64
        BLAKE2b of the seed and the name: stable across processes, Python
        runs and platforms (unlike the salted built-in ``hash``).

    """
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)):
        raise TypeError(f'seed must be an integer, got {seed!r}')
    seed = int(seed)
    if not 0 <= seed < 2 ** 64:
        raise ValueError(f'seed must be in [0, 2**64), got {seed}')
    digest = hashlib.blake2b(
        seed.to_bytes(8, 'little') + str(name).encode('utf-8'),
        digest_size=8, person=b'gps_error_ros').digest()
    return np.uint64(int.from_bytes(digest, 'little'))


def agent_keys(seed: int, names: Iterable[str]) -> npt.NDArray[np.uint64]:
    """Return the stream keys of several agents as a uint64 array."""
    return np.array([agent_key(seed, n) for n in names], dtype=np.uint64)


def _mix(z: npt.NDArray[np.uint64]) -> npt.NDArray[np.uint64]:
    """Return the SplitMix64 output function applied to uint64 array ``z``."""
    z = (z ^ (z >> _S30)) * _M1
    z = (z ^ (z >> _S27)) * _M2
    return z ^ (z >> _S31)


def _position(domain: int, index: Any) -> npt.NDArray[np.uint64]:
    index = np.asarray(index, dtype=np.int64)
    if np.any(index < 0) or np.any(index >= 2 ** COUNTER_BITS):
        raise ValueError(
            f'stream index must be in [0, 2**{COUNTER_BITS}), got {index}')
    return (np.uint64(domain) << np.uint64(COUNTER_BITS)) | \
        index.astype(np.uint64)


def _positions(keys: Any, domain: int, index: Any) -> npt.NDArray[np.uint64]:
    keys = np.asarray(keys, dtype=np.uint64)
    with np.errstate(over='ignore'):
        return keys + _position(domain, index) * _GAMMA


def uniform_pairs(keys: Any, domain: int, index: Any) -> npt.NDArray[np.float64]:
    """
    Return two uniforms in (0, 1) per key at one position of each stream.

    Parameters
    ----------
    keys
        The agents' stream keys (:func:`agent_key`).
    domain
        What the draw is for (``DOMAIN_STEP``, ``DOMAIN_INIT``, ...).
    index
        Position within the domain (for steps: the model step index).

    Returns
    -------
    numpy.ndarray, shape (n, 2)

    """
    with np.errstate(over='ignore'):
        word = _mix(_positions(keys, domain, index))
    out = np.empty(word.shape + (2,))
    out[..., 0] = ((word >> _S32).astype(np.float64) + 0.5) * _INV32
    out[..., 1] = ((word & _LOW32).astype(np.float64) + 0.5) * _INV32
    return out


_CHUNK = 1 << 14
_F32_INV32 = np.float32(_INV32)
_F32_HALF = np.float32(0.5)
_F32_TWO_PI_INV32 = np.float32(2.0 * np.pi * _INV32)


class _Workspace:
    """Cache-sized scratch arrays, reused across calls (not thread-safe)."""

    def __init__(self, n: int = _CHUNK) -> None:
        self.w = np.empty(n, np.uint64)
        self.t = np.empty(n, np.uint64)
        self.r = np.empty(n, np.float32)
        self.a = np.empty(n, np.float32)
        self.c = np.empty(n, np.float32)


_WS = _Workspace()


def _box_muller_into(pos: npt.NDArray[np.uint64], out_n: npt.NDArray[np.float64],
                     out_e: npt.NDArray[np.float64]) -> None:
    """Fill ``out_n``, ``out_e`` (m,) with the normal pair of each position."""
    m = pos.size
    ws = _WS
    w, t = ws.w[:m], ws.t[:m]
    r, a, c = ws.r[:m], ws.a[:m], ws.c[:m]
    with np.errstate(over='ignore'):
        np.right_shift(pos, _S30, out=t)
        np.bitwise_xor(pos, t, out=w)
        np.multiply(w, _M1, out=w)
        np.right_shift(w, _S27, out=t)
        np.bitwise_xor(w, t, out=w)
        np.multiply(w, _M2, out=w)
        np.right_shift(w, _S31, out=t)
        np.bitwise_xor(w, t, out=w)
    # Box-Muller in float32 (SIMD log/sin/cos): relative error ~1e-7.
    np.right_shift(w, _S32, out=t)
    r[:] = t
    np.bitwise_and(w, _LOW32, out=t)
    a[:] = t
    np.add(r, _F32_HALF, out=r)
    np.multiply(r, _F32_INV32, out=r)
    np.log(r, out=r)
    np.multiply(r, np.float32(-2.0), out=r)
    np.sqrt(r, out=r)
    np.add(a, _F32_HALF, out=a)
    np.multiply(a, _F32_TWO_PI_INV32, out=a)
    np.cos(a, out=c)
    np.multiply(r, c, out=out_n)
    np.sin(a, out=c)
    np.multiply(r, c, out=out_e)


def normal_pairs(keys: Any, domain: int, index: Any) -> npt.NDArray[np.float64]:
    """
    Return two independent standard normals per key (Box-Muller).

    Same arguments as :func:`uniform_pairs`; returns shape
    ``broadcast(keys, index).shape + (2,)``. The value at a position does not
    depend on what else is drawn in the same call.
    """
    pos = np.ascontiguousarray(_positions(keys, domain, index))
    out = np.empty(pos.shape + (2,))
    flat_pos = pos.reshape(-1)
    flat_out = out.reshape(-1, 2)
    for c0 in range(0, flat_pos.size, _CHUNK):
        c1 = min(c0 + _CHUNK, flat_pos.size)
        _box_muller_into(flat_pos[c0:c1], flat_out[c0:c1, 0], flat_out[c0:c1, 1])
    return out


def normal_block_axes(keys: Any, domain: int, start: int, count: int,
                      by_agent: bool = False) -> npt.NDArray[np.float64]:
    """
    Return normal pairs for consecutive indices, axis-major: (2, count, n).

    Entry ``[a, j, i]`` equals ``normal_pairs(keys, domain, start + j)[i, a]``;
    each axis is contiguous over (time, agent), for vectorised loops.
    ``by_agent``: shape (2, n, count) instead, entry ``[a, i, j]``, each
    agent's series contiguous (for a filter along time).
    """
    keys = np.asarray(keys, dtype=np.uint64)
    idx = np.arange(start, start + count, dtype=np.int64)
    pos = np.ascontiguousarray(_positions(keys[:, None], domain, idx[None, :]) if by_agent
                               else _positions(keys[None, :], domain, idx[:, None])).reshape(-1)
    out = np.empty((2, keys.size, count) if by_agent else (2, count, keys.size))
    on, oe = out[0].reshape(-1), out[1].reshape(-1)
    for c0 in range(0, pos.size, _CHUNK):
        c1 = min(pos.size, c0 + _CHUNK)
        _box_muller_into(pos[c0:c1], on[c0:c1], oe[c0:c1])
    return out


def normal_block(keys: Any, domain: int, start: int, count: int) -> npt.NDArray[np.float64]:
    """
    Return standard normal pairs for ``count`` consecutive indices.

    Returns shape (count, n, 2): entry ``[j]`` equals
    ``normal_pairs(keys, domain, start + j)``.
    """
    keys = np.asarray(keys, dtype=np.uint64)
    idx = np.arange(start, start + count, dtype=np.int64)[:, None]
    return normal_pairs(keys[None, :], domain, idx)
