"""The two engines behind every estimator: ``batched`` (default) and ``filterpy`` (reference).

An estimator (single sensor, centralized, federated, …) is written once, against
:class:`FilterBank` (K Kalman filters for each of N pairs) and two engine functions,
:meth:`Engine.fuse` and :meth:`Engine.nis`.  The engine decides how that algebra runs:

* ``filterpy``: one ``filterpy.kalman.KalmanFilter`` per filter per pair, and per-pair numpy
  for fusion and NIS.  Readable, trusted, slow: the reference.
* ``batched``: the same equations as numba kernels over all pairs at once
  (:mod:`acc_fusion.filters.kalman`).  The default; everything at scale runs on it.  The federated
  filter's whole step runs there as one kernel that applies the same per-filter operations
  pair by pair (:meth:`~acc_fusion.fusion.federated.FederatedFilter._advance_batched`): a call per
  operation cost more in Python than the operations themselves.

Tests hold the two equal to 1e-9 (``tests/test_engines.py``).
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np

from acc_fusion.core.errors import ConfigError
from acc_fusion.core.motion import STATE_DIM
from acc_fusion.core.slots import PairState
from acc_fusion.core.threads import blocks
from acc_fusion.core.validation import check_choice
from acc_fusion.filters import kalman

ENGINES = ("batched", "filterpy")


class FilterBank(PairState, ABC):
    """K Kalman filters of dimension ``dim`` for each of N pairs (e.g. one per sensor)."""

    def __init__(self, n_filters: int, n_pairs: int, dim: int) -> None:
        self.n_filters, self.n_pairs, self.dim = n_filters, n_pairs, dim

    def _resized(self, m: int) -> None:
        self.n_pairs = m

    @property
    @abstractmethod
    def x(self) -> np.ndarray:
        """States, shape ``(K, N, dim)`` (read-only view or copy)."""

    @property
    @abstractmethod
    def p(self) -> np.ndarray:
        """Covariances, shape ``(K, N, dim, dim)`` (read-only view or copy)."""

    @abstractmethod
    def predict(
        self,
        f: np.ndarray,
        q: np.ndarray,
        q_scale: np.ndarray,
        mask: np.ndarray,
        b: np.ndarray | None = None,
        u: np.ndarray | None = None,
    ):
        """Time update where ``mask (K, N)``, with process noise ``q_scale (K, N) * q`` and,
        when given, the known input ``u (N,)`` through ``b (dim,)``: ``x = F x + b u``."""

    @abstractmethod
    def update(
        self, j: int, z: np.ndarray, r: np.ndarray, h: np.ndarray, rows: np.ndarray
    ) -> np.ndarray:
        """Update filter ``j`` of every pair with its active measurement ``rows (N, m)``.

        ``z (N, m)``, ``r (N, m, m)``, ``h (m, dim)``.  Returns the NIS ``(N,)`` (NaN where no
        row was active).
        """

    @abstractmethod
    def assign(
        self,
        j: int,
        mask: np.ndarray,
        x: np.ndarray,
        p: np.ndarray,
        p_scale: np.ndarray | None = None,
    ) -> None:
        """Set filter ``j`` of the pairs in ``mask (N,)`` to ``x (N, dim)`` and ``p (N, dim,
        dim)``, times ``p_scale (N,)`` when given."""


class BatchedBank(FilterBank):
    """All filters in two contiguous arrays, updated by the numba kernels (whose state
    dimension is :data:`~acc_fusion.core.motion.STATE_DIM`, a compile-time constant)."""

    _PAIR_AXES = {"_x": 1, "_p": 1}

    def __init__(self, n_filters: int, n_pairs: int, dim: int) -> None:
        if dim != STATE_DIM:
            raise ConfigError(f"the batched engine's filters have dimension {STATE_DIM}, got {dim}")
        super().__init__(n_filters, n_pairs, dim)
        self._x = np.zeros((n_filters, n_pairs, dim))
        self._p = np.tile(np.eye(dim), (n_filters, n_pairs, 1, 1))

    @property
    def x(self) -> np.ndarray:
        return self._x

    @property
    def p(self) -> np.ndarray:
        return self._p

    def predict(self, f, q, q_scale, mask, b=None, u=None):
        k, n, d = self._x.shape
        args = (
            self._x.reshape(k * n, d),
            self._p.reshape(k * n, d, d),
            np.ascontiguousarray(f, dtype=float),
            np.ascontiguousarray(q, dtype=float),
            _per_filter(q_scale, (k, n), float),
            _per_filter(mask, (k, n), bool),
            *kalman.input_args(b, u),
        )
        chunks = blocks(k * n, kalman.PARALLEL_PAIRS)
        kalman.predict_parallel(*args, chunks) if chunks else kalman.predict(*args)

    def update(self, j, z, r, h, rows):
        nis = np.empty(self.n_pairs)
        args = (self._x[j], self._p[j], *_measurement_args(z, r, h, rows), nis)
        chunks = blocks(self.n_pairs, kalman.PARALLEL_PAIRS)
        kalman.update_parallel(*args, chunks) if chunks else kalman.update(*args)
        return nis

    def assign(self, j, mask, x, p, p_scale=None):
        scale = np.ones(self.n_pairs) if p_scale is None else p_scale
        args = ((mask, bool), (x, float), (p, float), (scale, float))
        kalman.assign(self._x[j], self._p[j], *(np.ascontiguousarray(a, t) for a, t in args))


def _per_filter(a, shape: tuple[int, int], dtype) -> np.ndarray:
    """``a`` broadcast to ``shape`` (K, N) as a flat contiguous array of ``dtype`` (no copy
    when it already is one: the kernels' per-filter arguments)."""
    a = np.asarray(a, dtype=dtype)
    if a.shape == shape and a.flags.c_contiguous:
        return a.reshape(-1)
    out = np.empty(shape, dtype=dtype)
    out[...] = a
    return out.reshape(-1)


class FilterpyBank(FilterBank):
    """One ``filterpy.kalman.KalmanFilter`` per filter per pair (the reference engine)."""

    def __init__(self, n_filters: int, n_pairs: int, dim: int) -> None:
        super().__init__(n_filters, n_pairs, dim)
        self._kf = [[self._new(dim) for _ in range(n_pairs)] for _ in range(n_filters)]

    def resize(self, m: int) -> None:
        """Hold the filters of the first ``m`` pairs; the others are parked as they are."""
        parked = self.__dict__.setdefault("_parked", [[] for _ in self._kf])
        for j, row in enumerate(self._kf):
            full = row + parked[j]
            if not 1 <= m <= len(full):
                raise ConfigError(f"FilterpyBank can hold 1 to {len(full)} pairs, got {m}")
            self._kf[j], parked[j] = full[:m], full[m:]
        self._resized(m)

    @staticmethod
    def _new(dim: int):
        # Imported here: filterpy imports scipy.stats (0.8 s), which the batched engine needs not.
        from filterpy.kalman import KalmanFilter

        kf = KalmanFilter(dim_x=dim, dim_z=1)
        kf.x = np.zeros(dim)
        return kf

    @property
    def x(self) -> np.ndarray:
        return np.array([[kf.x for kf in row] for row in self._kf], dtype=float)

    @property
    def p(self) -> np.ndarray:
        return np.array([[kf.P for kf in row] for row in self._kf], dtype=float)

    def predict(self, f, q, q_scale, mask, b=None, u=None):
        q_scale = np.broadcast_to(q_scale, (self.n_filters, self.n_pairs))
        for j, row in enumerate(self._kf):
            for k in np.flatnonzero(np.broadcast_to(mask, q_scale.shape)[j]):
                if u is None:
                    row[k].predict(F=f, Q=q_scale[j, k] * q)
                else:
                    row[k].predict(u=u[k], B=b, F=f, Q=q_scale[j, k] * q)

    def update(self, j, z, r, h, rows):
        nis = np.full(self.n_pairs, np.nan)
        for k in np.flatnonzero(rows.any(axis=1)):
            sel = rows[k]
            kf = self._kf[j][k]
            kf.update(z[k, sel], R=r[k][np.ix_(sel, sel)], H=h[sel])
            nis[k] = kf.mahalanobis**2  # filterpy's mahalanobis is sqrt(NIS)
        return nis

    def assign(self, j, mask, x, p, p_scale=None):
        for k in np.flatnonzero(mask):
            kf = self._kf[j][k]
            kf.x = np.array(x[k], dtype=float)
            kf.P = np.array(p[k] if p_scale is None else p[k] * p_scale[k], dtype=float)


class Engine:
    """Factory of filter banks plus the fusion and NIS algebra of one engine."""

    def __init__(self, name: str = "batched") -> None:
        self.name = check_choice("engine", name, ENGINES)

    def bank(self, n_filters: int, n_pairs: int, dim: int) -> FilterBank:
        """A new bank of ``n_filters`` filters for each of ``n_pairs`` pairs."""
        cls = BatchedBank if self.name == "batched" else FilterpyBank
        return cls(n_filters, n_pairs, dim)

    def fuse(
        self,
        xs: np.ndarray,
        ps: np.ndarray,
        active: np.ndarray,
        x_prior: np.ndarray,
        p_prior: np.ndarray,
        increments: bool,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Information fusion of local estimates (see :func:`acc_fusion.filters.kalman.fuse`)."""
        if self.name == "batched":
            x_out = np.empty_like(x_prior)
            p_out = np.empty_like(p_prior)
            kalman.fuse(
                np.ascontiguousarray(xs),
                np.ascontiguousarray(ps),
                np.ascontiguousarray(active),
                np.ascontiguousarray(x_prior),
                np.ascontiguousarray(p_prior),
                increments,
                x_out,
                p_out,
            )
            return x_out, p_out
        x_out, p_out = x_prior.copy(), p_prior.copy()
        for k in np.flatnonzero(active.any(axis=0)):
            ym = np.linalg.inv(p_prior[k])
            w = (1.0 - active[:, k].sum()) if increments else 0.0
            info, vec = w * ym, w * ym @ x_prior[k]
            for i in np.flatnonzero(active[:, k]):
                yi = np.linalg.inv(ps[i, k])
                info, vec = info + yi, vec + yi @ xs[i, k]
            pk = np.linalg.inv(info)
            x_out[k], p_out[k] = pk @ vec, 0.5 * (pk + pk.T)
        return x_out, p_out

    def nis(
        self, x: np.ndarray, p: np.ndarray, z: np.ndarray, r: np.ndarray, h: np.ndarray, rows
    ) -> np.ndarray:
        """NIS of measurement rows ``(N, m)`` against the priors ``x (N, n)``, ``p (N, n, n)``."""
        out = np.full(x.shape[0], np.nan)
        if self.name == "batched":
            args = (np.ascontiguousarray(x), np.ascontiguousarray(p),
                    *_measurement_args(z, r, h, rows), out)  # fmt: skip
            chunks = blocks(x.shape[0], kalman.PARALLEL_PAIRS)
            if chunks:
                kalman.innovation_nis_parallel(*args, chunks)
            else:
                kalman.innovation_nis(*args)
            return out
        for k in np.flatnonzero(rows.any(axis=1)):
            sel = rows[k]
            y = z[k, sel] - h[sel] @ x[k]
            s = h[sel] @ p[k] @ h[sel].T + r[k][np.ix_(sel, sel)]
            out[k] = y @ np.linalg.solve(s, y)
        return out


def _measurement_args(z, r, h, rows) -> tuple[np.ndarray, ...]:
    """``z``, ``r``, ``h`` and ``rows`` as the batched kernels take them (contiguous float
    arrays, ``rows`` boolean)."""
    floats = (np.ascontiguousarray(a, dtype=float) for a in (z, r, h))
    return (*floats, np.ascontiguousarray(rows, dtype=bool))
