"""
The paper's AR(p) position-error process (Eq. 2-3), vectorised over agents.

Each horizontal axis (north = latitude error, east = longitude error, metres)
follows ``e(t) = delta + sum_i phi_i e(t-i) + w(t)`` on the model's grid. The
process is carried as deviations from its mean ``m = delta / (1 - sum phi)``
in companion (state-space) form, so its exact stationary covariance follows
from the discrete Lyapunov equation rather than from simulation.

Sign convention (written once): the AR polynomial is
``a(z) = 1 - phi_1 z - ... - phi_p z**p``; the process is stationary when all
roots of ``a(z)`` lie strictly outside the unit circle.
"""

from dataclasses import dataclass

import numpy as np
from typing import Any, Optional
import numpy.typing as npt

from gps_error_ros.model import streams
from gps_error_ros.model.protocol import Inputs, Process
from gps_error_ros.model.state import ARState, FloatArray, Keys, Numbers

AXES = ('north', 'east')
#: Largest AR order: the initial state's pairs must fit the stream slots.
MAX_ORDER = streams.INIT_SLOTS


class ModelError(ValueError):
    """An AR specification that cannot define a stationary error process."""


def ar_roots(phi: Numbers) -> npt.NDArray[Any]:
    """Return the roots of ``1 - phi_1 z - ... - phi_p z**p``."""
    phi = np.asarray(phi, dtype=float)
    # numpy.roots wants the highest power first.
    return np.roots(np.r_[-phi[::-1], 1.0])


def inverse_root_modulus(phi: Numbers) -> float:
    """
    Return the largest modulus of the inverse AR roots (spectral radius).

    The eigenvalues of the companion matrix are the inverses of the roots of
    ``1 - phi_1 z - ... - phi_p z**p``; computed this way tiny coefficients
    give tiny eigenvalues instead of overflowing roots.
    """
    phi = np.asarray(phi, dtype=float)
    if phi.size == 0:
        return 0.0
    comp = np.zeros((phi.size, phi.size))
    comp[0] = phi
    comp[1:, :-1] = np.eye(phi.size - 1)
    return float(np.max(np.abs(np.linalg.eigvals(comp))))


def is_stationary(phi: Numbers, margin: float = 0.0) -> bool:
    """Return True when every AR root lies outside the unit circle (+margin)."""
    phi = np.asarray(phi, dtype=float)
    if phi.size == 0 or not np.any(phi):
        return True
    return inverse_root_modulus(phi) * (1.0 + margin) < 1.0


@dataclass(frozen=True)
class AxisParams:
    """
    AR(p) parameters of one axis, as in the paper's Table II.

    Attributes
    ----------
    delta : float
        Constant term (metres), ``delta = (1 - sum phi) * mean``.
    phi : tuple of float
        AR coefficients phi_1..phi_p; the order is ``len(phi)``.
    sigma_w : float
        Standard deviation of the white innovation noise (metres).

    """

    delta: float
    phi: tuple[float, ...]
    sigma_w: float

    def __post_init__(self) -> None:
        object.__setattr__(self, 'phi', tuple(float(v) for v in self.phi))
        values = (self.delta, self.sigma_w) + self.phi
        if not all(np.isfinite(v) for v in values):
            raise ModelError(f'AR parameters must be finite, got {self}')
        if len(self.phi) < 1:
            raise ModelError('phi must hold at least one coefficient (p >= 1)')
        if len(self.phi) > MAX_ORDER:
            raise ModelError(f'phi holds {len(self.phi)} coefficients: the '
                             f'largest order supported is {MAX_ORDER}')
        if not 1e-6 <= self.sigma_w <= 1e6:
            raise ModelError(f'sigma_w must be in [1e-6, 1e6] m (> 0 and '
                             f'representable squared), got {self.sigma_w}')
        if not is_stationary(self.phi):
            rho = inverse_root_modulus(self.phi)
            smallest = 1.0 / rho if rho > 0 else float('inf')
            raise ModelError(
                f'phi={list(self.phi)} is not stationary: the smallest root '
                f'modulus of 1 - sum phi_i z^i is {smallest:.4f}, expected > 1')

    @property
    def order(self) -> int:
        """Return the AR order p."""
        return len(self.phi)

    @property
    def mean(self) -> float:
        """Return the process mean ``delta / (1 - sum phi)`` (Eq. 3)."""
        return self.delta / (1.0 - sum(self.phi))


def stationary_cov(a: FloatArray, q: FloatArray) -> FloatArray:
    """
    Return the stationary covariance ``x = a x a' + q`` of ``s(t) = a s(t-1) + noise``.

    Solved directly on its vectorised form, ``(I - a (x) a) vec(x) = vec(q)``
    (the state is at most a few dozen wide); numpy alone, so that a node
    need not import scipy to start.
    """
    n = a.shape[0]
    lhs = np.eye(n * n) - np.kron(a, a)
    return np.linalg.solve(lhs, q.reshape(-1)).reshape(n, n)


def _sqrt_psd(cov: FloatArray) -> FloatArray:
    """
    Return L with L @ L.T == cov: Cholesky, or from eigenvalues.

    Near a unit root the stationary covariance can be positive definite in
    exact arithmetic but not in floating point; the eigen-decomposition
    (negative rounding clipped to 0) still gives a valid square root.
    """
    try:
        return np.linalg.cholesky(cov)
    except np.linalg.LinAlgError:
        w, v = np.linalg.eigh(cov)
        return v * np.sqrt(np.clip(w, 0.0, None))


class ARErrorModel(Process[ARState]):
    """
    Two-axis AR error process with exact stationary moments.

    Parameters
    ----------
    north
        The north axis' parameters; the orders may differ (the shorter is
        zero-padded).
    east
        The east axis' parameters.
    innovation_corr
        Correlation of the north and east innovations (0 in the paper).

    """

    #: No motion lag (see :class:`effects.ExtendedModel`).
    lag_s = 0.0
    #: The innovations do not turn with the direction of travel (street_frame).
    needs_heading = False

    def __init__(self, north: AxisParams, east: AxisParams,
                 innovation_corr: float = 0.0) -> None:
        if not -1.0 < innovation_corr < 1.0:
            raise ModelError(
                f'innovation_corr must be in (-1, 1), got {innovation_corr}')
        self.axes = (north, east)
        p = max(north.order, east.order)
        self.order = p
        self.phi = np.zeros((2, p))
        for a, ax in enumerate(self.axes):
            self.phi[a, :ax.order] = ax.phi
        self.mean = np.array([ax.mean for ax in self.axes])
        sw = np.array([ax.sigma_w for ax in self.axes])
        self.innovation_cov = np.array(
            [[sw[0] ** 2, innovation_corr * sw[0] * sw[1]],
             [innovation_corr * sw[0] * sw[1], sw[1] ** 2]])
        self._innovation_chol = np.linalg.cholesky(self.innovation_cov)
        self.transition = self._companion()
        noise_map = np.zeros((2 * p, 2))
        noise_map[0, 0] = 1.0
        noise_map[p, 1] = 1.0
        self.state_cov = stationary_cov(self.transition,
                                        noise_map @ self.innovation_cov @ noise_map.T)
        self.state_cov = 0.5 * (self.state_cov + self.state_cov.T)
        if not np.all(np.isfinite(self.state_cov)):
            raise ModelError('the stationary covariance is not finite (a root '
                             'too close to the unit circle)')
        self._state_chol = _sqrt_psd(self.state_cov)

    def _companion(self) -> FloatArray:
        p = self.order
        a = np.zeros((2 * p, 2 * p))
        for ax in range(2):
            o = ax * p
            a[o, o:o + p] = self.phi[ax]
            a[o + 1:o + p, o:o + p - 1] += np.eye(p - 1)
        return a

    @property
    def stationary_cov(self) -> FloatArray:
        """Return the 2x2 (north, east) covariance of the error about its mean."""
        i = [0, self.order]
        return self.state_cov[np.ix_(i, i)].copy()

    @property
    def stationary_sd(self) -> FloatArray:
        """Return the stationary standard deviation per axis (north, east)."""
        return np.sqrt(np.diag(self.stationary_cov))

    def autocovariance(self, max_lag: int) -> FloatArray:
        """
        Return the exact autocovariance, shape (max_lag + 1, 2, 2).

        Entry ``[k, i, j]`` is ``Cov(e_i(t + k), e_j(t))`` with axes ordered
        (north, east).
        """
        i = [0, self.order]
        out = np.empty((max_lag + 1, 2, 2))
        cov = self.state_cov
        for k in range(max_lag + 1):
            out[k] = cov[np.ix_(i, i)]
            cov = self.transition @ cov
        return out

    def autocorrelation(self, max_lag: int) -> FloatArray:
        """Return the exact autocorrelation per axis, shape (max_lag + 1, 2)."""
        acv = self.autocovariance(max_lag)
        diag = np.stack([acv[:, 0, 0], acv[:, 1, 1]], axis=1)
        return diag / diag[0]

    # --- simulation -----------------------------------------------------

    def initial_state(self, keys: Keys, index: int, inputs: Inputs = None) -> ARState:
        """
        Draw the state at model step ``index`` from the stationary law.

        Returns an :class:`~.state.ARState`: the deviations from the mean.
        ``inputs`` is accepted for the protocol's sake and not used.
        """
        keys = np.atleast_1d(np.asarray(keys, dtype=np.uint64))
        p = self.order
        z = np.empty((keys.size, 2 * p))
        for j in range(p):
            z[:, 2 * j:2 * j + 2] = streams.normal_pairs(
                keys, streams.DOMAIN_INIT, streams.init_position(index, j))
        # x = L z, written out so that an agent's numbers never depend on how
        # many agents are drawn together (BLAS may reorder sums by size).
        x = np.zeros((keys.size, 2 * p))
        for i in range(2 * p):
            for j in range(2 * p):
                if self._state_chol[i, j] != 0.0:
                    x[:, i] += self._state_chol[i, j] * z[:, j]
        return ARState(x.reshape(keys.size, 2, p))

    def predictive_cov(self, state: ARState, first: bool = False) -> FloatArray:
        """
        Return each agent's covariance (n, 2, 2) of the next error given ``state``.

        For the AR process this is the innovation covariance, the same for
        every agent and step. ``first``: the covariance of a run's first
        error, which is drawn from the stationary law, so the stationary
        covariance (nothing before it is known).
        """
        if first:
            return np.repeat(self.stationary_cov[None], len(state), axis=0)
        return np.repeat(self.innovation_cov[None], len(state), axis=0)

    def mean_step_cov(self) -> FloatArray:
        """
        Return the one-step covariance (2, 2) averaged over the stationary law.

        The reference scale of a stated radius that follows the predictive
        covariance (:func:`~.reported.reference_cov`); for the AR process the
        innovation covariance.
        """
        return self.innovation_cov.copy()

    def predictive_mean(self, state: ARState, first: bool = False) -> FloatArray:
        """
        Return each agent's expected next error (n, 2) given ``state``, mean included.

        ``delta``'s mean plus the AR part of the deviations held
        (``first``: the stationary mean).
        """
        if first:
            return np.repeat(self.mean[None], len(state), axis=0)
        out = np.repeat(self.mean[None], len(state), axis=0)
        dev = state.deviations
        for i in range(self.order):
            out += self.phi[:, i] * dev[:, :, i]
        return out

    def empty_state(self, n: int) -> ARState:
        """Return the state of ``n`` agents, all zeros."""
        return ARState(np.zeros((n, 2, self.order)))

    def prepare(self, state: ARState, keys: Keys, index: int, inputs: Inputs = None) -> None:
        """Do nothing: the AR process takes no inputs."""

    def carried(self, state: ARState) -> FloatArray:
        """Return the last ``p`` errors (n, 2, p), mean included, newest first (zones)."""
        return state.deviations + self.mean[None, :, None]

    def resumed(self, carried: FloatArray, keys: Keys, index: int,
                inputs: Inputs = None) -> ARState:
        """
        Return the state of agents entering this process at ``index`` with errors ``carried``.

        ``carried`` (n, 2, P >= p): the last errors under the process they
        leave (:meth:`carried`), newest first. The state is the one before
        step ``index``: the recursion continues from those errors.
        """
        return ARState(carried[:, :, :self.order] - self.mean[None, :, None])

    def state_after(self, keys: Keys, start: int, step: int, inputs: Inputs = None) -> ARState:
        """
        Return the state at model step ``step`` of a run started at ``start``.

        ``inputs`` is accepted for the protocol's sake and not used.
        """
        keys = np.atleast_1d(np.asarray(keys, dtype=np.uint64))
        span = step - start + 1
        p = self.order
        if span >= p:
            series = self.simulate(keys, span, start=start)
            return ARState(np.stack([series[-1 - i] - self.mean for i in range(p)],
                                    axis=-1))
        state = self.initial_state(keys, start)
        for s in range(start + 1, step + 1):
            self.advance(state, keys, s)
        return state

    def _innovations(self, z: FloatArray) -> FloatArray:
        """Return innovations from standard normals ``z`` (..., 2), elementwise."""
        c = self._innovation_chol
        w = np.empty_like(z)
        w[..., 0] = c[0, 0] * z[..., 0]
        w[..., 1] = c[1, 1] * z[..., 1]
        if c[1, 0] != 0.0:
            w[..., 1] += c[1, 0] * z[..., 0]
        return w

    def advance(self, state: ARState, keys: Keys, index: int,
                inputs: Inputs = None) -> FloatArray:
        """
        Advance ``state`` in place to model step ``index``; return errors.

        The innovation of step ``index`` is drawn from each key's stream at
        that index. Returns the errors (mean included), shape (n, 2).
        ``inputs`` is accepted for the protocol's sake and not used.
        """
        z = streams.normal_pairs(keys, streams.DOMAIN_STEP, index)
        return self.advance_with(state, z)

    def advance_with(self, state: ARState, z: FloatArray) -> FloatArray:
        """Advance ``state`` in place with standard-normal draws ``z`` (n, 2)."""
        dev = state.deviations
        new = self._innovations(z)
        for i in range(self.order):
            new += self.phi[:, i] * dev[:, :, i]
        for i in range(self.order - 1, 0, -1):     # lag by lag: no overlapping copy
            dev[:, :, i] = dev[:, :, i - 1]
        dev[:, :, 0] = new
        return new + self.mean

    def errors(self, state: ARState) -> FloatArray:
        """Return the current errors of ``state`` (mean included), (n, 2)."""
        return state.deviations[:, :, 0] + self.mean

    def simulate(self, keys: Keys, n_steps: int, start: int = 0,
                 out: Optional[FloatArray] = None) -> FloatArray:
        """
        Simulate errors at model steps ``start .. start + n_steps - 1``.

        The state at ``start`` is drawn from the stationary law; step ``k``
        uses each key's innovation at stream index ``k``, as :meth:`advance`
        does. Vectorised over agents and time: crowds (>= 1024 agents) step
        through time over cache-sized chunks of agents with the node's own
        arithmetic (bit-identical to :meth:`advance`); a few long series run
        the recursion in ``scipy.signal.lfilter`` (equal to rounding, ~1e-13).

        Parameters
        ----------
        keys
            The agents' stream keys (:func:`~.streams.agent_keys`).
        n_steps
            Model steps to simulate.
        start
            The first model step (the stream index of the initial state).
        out
            Where to write the result.

        Returns
        -------
        numpy.ndarray, shape (n_steps, n_agents, 2)
            Errors in metres, axes (north, east); written into ``out`` when
            given (any array of that shape, e.g. a memory map).

        """
        keys = np.atleast_1d(np.asarray(keys, dtype=np.uint64))
        n = keys.size
        if out is None:
            out = np.empty((n_steps, n, 2))
        if n_steps == 0:
            return out
        if n >= 1024:
            # equal chunks of at most 16384 agents: rows stay in cache and no
            # small remainder chunk pays the per-step overhead alone
            run, chunk = self._simulate_steps, -(-n // -(-n // 16384))
        else:
            run, chunk = self._simulate_lfilter, max(1, min(n, (1 << 21) // n_steps))
        for a0 in range(0, n, chunk):
            a1 = min(n, a0 + chunk)
            run(keys[a0:a1], n_steps, start, out[:, a0:a1])
        return out

    def _noise_innovations(self, keys: Keys, start: int, count: int,
                           by_agent: bool = False) -> FloatArray:
        """Return innovations (2, count, m) as the node computes them (``by_agent``: m first)."""
        z = streams.normal_block_axes(keys, streams.DOMAIN_STEP, start, count, by_agent)
        c = self._innovation_chol
        z[1] *= c[1, 1]
        if c[1, 0] != 0.0:
            z[1] += c[1, 0] * z[0]
        z[0] *= c[0, 0]
        return z

    def _simulate_steps(self, keys: Keys, n_steps: int, start: int, out: FloatArray) -> None:
        # Axis-major history (axis, time, agent): inner loops run over agents.
        p, m = self.order, keys.size
        state = self.initial_state(keys, start)
        block = max(1, (1 << 19) // (2 * m))
        hist = np.empty((2, p + block, m))
        for i in range(p):
            hist[:, p - 1 - i] = state.deviations[:, :, i].T
        out[0] = self.errors(state)
        tmp = np.empty((2, m))
        phi = [self.phi[:, i:i + 1].copy() for i in range(p)]
        for t0 in range(1, n_steps, block):
            cnt = min(block, n_steps - t0)
            hist[:, p:p + cnt] = self._noise_innovations(keys, start + t0, cnt)
            for j in range(p, p + cnt):
                row = hist[:, j]
                for i in range(p):
                    np.multiply(hist[:, j - 1 - i], phi[i], out=tmp)
                    np.add(row, tmp, out=row)
            for ax in range(2):
                np.add(hist[ax, p:p + cnt], self.mean[ax], out=out[t0:t0 + cnt, :, ax])
            hist[:, :p] = hist[:, cnt:cnt + p]

    def _simulate_lfilter(self, keys: Keys, n_steps: int, start: int, out: FloatArray) -> None:
        # imported here: scipy.signal takes about a second to import, and a
        # node stepping its agents one fix at a time never needs it
        from scipy import signal
        p, m = self.order, keys.size
        state = self.initial_state(keys, start)
        out[0] = self.errors(state)
        # lfilter's direct-form-II-transposed state from the AR history:
        # zi[i] = sum_{j > i} phi_j * y[-(j - i)]
        zi = np.zeros((2, m, p))
        for ax in range(2):
            for i in range(p):
                for j in range(i + 1, p + 1):
                    zi[ax, :, i] += self.phi[ax, j - 1] * state.deviations[:, ax, j - i - 1]
        t_block = max(1, (1 << 21) // m)
        for t0 in range(1, n_steps, t_block):
            t1 = min(n_steps, t0 + t_block)
            w = self._noise_innovations(keys, start + t0, t1 - t0, by_agent=True)   # (2, m, T)
            for ax in range(2):
                y, zi[ax] = signal.lfilter([1.0], np.r_[1.0, -self.phi[ax]],
                                           w[ax], axis=-1, zi=zi[ax])
                np.add(y.T, self.mean[ax], out=out[t0:t1, :, ax])
