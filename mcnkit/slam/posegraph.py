"""A 2-D pose graph and its least-squares solution (sparse Gauss-Newton / Levenberg-Marquardt).

Nodes are poses ``[x_m, y_m, yaw_rad]``; an edge ``(i, j, z, Ω)`` says that pose ``j`` seen from pose ``i`` is
``z`` with information (inverse covariance) ``Ω``.  Its error is ``e = z⁻¹ ⊕ (xᵢ⁻¹ ⊕ xⱼ)`` as a vector, and
the solution minimises ``Σ ρ(eᵀ Ω e)`` with ``ρ`` the identity for trusted edges and Huber's function for
edges marked ``robust`` (loop closures: a wrong one is down-weighted instead of bending the whole map).
The first node is held fixed.  Every iteration is one sparse linear solve over all nodes at once (Grisetti
et al., "A tutorial on graph-based SLAM", 2010).

Example:
    >>> poses = np.array([[0.0, 0.0, 0.0], [1.1, 0.0, 0.0], [2.3, 0.1, 0.0]])
    >>> edges = Edges.of([(0, 1, [1, 0, 0]), (1, 2, [1, 0, 0]), (0, 2, [2, 0, 0])], np.eye(3))
    >>> np.round(optimize(poses, edges), 3).tolist()
    [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]]
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import sparse
from scipy.sparse import linalg

__all__ = ["Edges", "edge_errors", "optimize"]

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]


@dataclass(frozen=True)
class Edges:
    """E relative-pose measurements: ``i``, ``j`` (E,), ``z`` (E, 3), ``info`` (E, 3, 3), ``robust`` (E,)."""

    i: I64
    j: I64
    z: F64
    info: F64
    robust: NDArray[np.bool_]

    def __post_init__(self) -> None:
        e = len(self.i)
        if self.j.shape != (e,) or self.z.shape != (e, 3) or self.info.shape != (e, 3, 3) or self.robust.shape != (e,):
            raise ValueError("edges need i, j (E,), z (E, 3), info (E, 3, 3) and robust (E,)")

    def __len__(self) -> int:
        return len(self.i)

    @classmethod
    def of(cls, items: Sequence[tuple[int, int, ArrayLike]], info: ArrayLike, robust: bool = False) -> Edges:
        """Edges from ``(i, j, z)`` triples sharing one information matrix."""
        n = len(items)
        return cls(
            np.array([it[0] for it in items], np.int64).reshape(n),
            np.array([it[1] for it in items], np.int64).reshape(n),
            np.array([it[2] for it in items], np.float64).reshape(n, 3),
            np.broadcast_to(np.asarray(info, np.float64), (n, 3, 3)).copy(),
            np.full(n, robust),
        )

    def subset(self, keep: NDArray[np.bool_]) -> Edges:
        """The edges where ``keep`` (E,) is True."""
        return Edges(self.i[keep], self.j[keep], self.z[keep], self.info[keep], self.robust[keep])

    @classmethod
    def concat(cls, parts: Sequence[Edges]) -> Edges:
        """All edges of ``parts``, in order."""
        if not parts:
            return cls.of([], np.eye(3))
        return cls(
            np.concatenate([p.i for p in parts]),
            np.concatenate([p.j for p in parts]),
            np.concatenate([p.z for p in parts]),
            np.concatenate([p.info for p in parts]),
            np.concatenate([p.robust for p in parts]),
        )


def _rot(theta: F64) -> tuple[F64, F64]:
    return np.cos(theta), np.sin(theta)


def edge_errors(poses: F64, edges: Edges) -> F64:
    """The error vectors (E, 3) of every edge at ``poses`` (K, 3)."""
    xi, xj = poses[edges.i], poses[edges.j]
    ci, si = _rot(xi[:, 2])
    cz, sz = _rot(edges.z[:, 2])
    dx, dy = xj[:, 0] - xi[:, 0], xj[:, 1] - xi[:, 1]
    tx = ci * dx + si * dy - edges.z[:, 0]  # Rᵢᵀ (tⱼ - tᵢ) - t_z
    ty = -si * dx + ci * dy - edges.z[:, 1]
    e = np.empty((len(edges), 3))
    e[:, 0] = cz * tx + sz * ty  # R_zᵀ (...)
    e[:, 1] = -sz * tx + cz * ty
    e[:, 2] = (xj[:, 2] - xi[:, 2] - edges.z[:, 2] + np.pi) % (2 * np.pi) - np.pi
    return e


def _jacobians(poses: F64, edges: Edges) -> tuple[F64, F64]:
    """∂e/∂xᵢ and ∂e/∂xⱼ (E, 3, 3)."""
    xi, xj = poses[edges.i], poses[edges.j]
    ci, si = _rot(xi[:, 2])
    cz, sz = _rot(edges.z[:, 2])
    dx, dy = xj[:, 0] - xi[:, 0], xj[:, 1] - xi[:, 1]
    n = len(edges)
    rzt = np.empty((n, 2, 2))  # R_zᵀ
    rzt[:, 0, 0], rzt[:, 0, 1], rzt[:, 1, 0], rzt[:, 1, 1] = cz, sz, -sz, cz
    rit = np.empty((n, 2, 2))  # Rᵢᵀ
    rit[:, 0, 0], rit[:, 0, 1], rit[:, 1, 0], rit[:, 1, 1] = ci, si, -si, ci
    drit = np.stack([-si * dx + ci * dy, -ci * dx - si * dy], axis=-1)  # (dRᵢᵀ/dθ)(tⱼ - tᵢ)
    rr = rzt @ rit
    a = np.zeros((n, 3, 3))
    b = np.zeros((n, 3, 3))
    a[:, :2, :2] = -rr
    a[:, :2, 2] = np.einsum("nab,nb->na", rzt, drit)
    a[:, 2, 2] = -1.0
    b[:, :2, :2] = rr
    b[:, 2, 2] = 1.0
    return a, b


def _robust_weights(chi2: F64, robust: NDArray[np.bool_], huber: float) -> F64:
    w = np.ones_like(chi2)
    r = np.sqrt(np.maximum(chi2, 0.0))
    big = robust & (r > huber)
    w[big] = huber / r[big]
    return w


def _cost(poses: F64, edges: Edges, huber: float) -> float:
    e = edge_errors(poses, edges)
    chi2 = np.einsum("na,nab,nb->n", e, edges.info, e)
    r = np.sqrt(np.maximum(chi2, 0.0))
    rho = np.where(edges.robust & (r > huber), 2 * huber * r - huber**2, chi2)
    return float(rho.sum())


def optimize(
    poses: F64, edges: Edges, iterations: int = 20, huber: float = 3.0, fixed: int = 0, tolerance: float = 1e-6
) -> F64:
    """The poses (K, 3) minimising the (robust) squared errors of ``edges``; node ``fixed`` does not move.

    Levenberg-Marquardt: a step that raises the cost is undone and the damping raised.  Stops after
    ``iterations`` or when no pose moves by more than ``tolerance``.
    """
    x = np.array(poses, dtype=np.float64)
    k = len(x)
    if len(edges) == 0 or k < 2:
        return x
    if edges.i.min() < 0 or edges.j.min() < 0 or max(edges.i.max(), edges.j.max()) >= k:
        raise ValueError(f"edges refer to nodes outside 0..{k - 1}")
    lam = 1e-6
    cost = _cost(x, edges, huber)
    rows = np.concatenate([3 * edges.i[:, None] + np.arange(3), 3 * edges.j[:, None] + np.arange(3)], axis=1)
    r_idx = np.repeat(rows, 6, axis=1).ravel()  # (E·36,) row of each entry of each edge's 6 × 6 block
    c_idx = np.tile(rows, (1, 6)).ravel()
    keep = np.ones(3 * k, bool)
    keep[3 * fixed : 3 * fixed + 3] = False
    for _ in range(iterations):
        e = edge_errors(x, edges)
        a, b = _jacobians(x, edges)
        chi2 = np.einsum("na,nab,nb->n", e, edges.info, e)
        info = edges.info * _robust_weights(chi2, edges.robust, huber)[:, None, None]
        jac = np.concatenate([a, b], axis=2)  # (E, 3, 6)
        blocks = np.einsum("nai,nab,nbj->nij", jac, info, jac)  # (E, 6, 6)
        grad = np.einsum("nai,nab,nb->ni", jac, info, e)  # (E, 6)
        h = sparse.coo_matrix((blocks.ravel(), (r_idx, c_idx)), shape=(3 * k, 3 * k)).tocsc()
        g = np.bincount(rows.ravel(), weights=grad.ravel(), minlength=3 * k)
        h = h[keep][:, keep]
        g = g[keep]
        diag = h.diagonal()
        while True:
            damped = h + sparse.diags(lam * (diag + 1e-9), format="csc")
            step = np.zeros(3 * k)
            step[keep] = linalg.spsolve(damped, -g)
            trial = x + step.reshape(k, 3)
            trial[:, 2] = (trial[:, 2] + np.pi) % (2 * np.pi) - np.pi
            new_cost = _cost(trial, edges, huber)
            if new_cost <= cost or lam > 1e6:
                break
            lam *= 10.0
        if new_cost > cost:
            break
        x, cost = trial, new_cost
        lam = max(lam / 10.0, 1e-9)
        if np.abs(step).max() < tolerance:
            break
    return x
