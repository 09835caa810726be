r"""Optimal 2-D assignment and global-nearest-neighbour (GNN) association, compiled.

:func:`assign` solves the rectangular linear assignment problem: given an ``(n_r, n_c)`` cost
matrix with :math:`n_r \le n_c`, find the column :math:`c(i)` of every row, all different,
minimising :math:`\sum_i C_{i, c(i)}`; an entry of ``inf`` is a forbidden pairing.  The
method is the shortest augmenting path algorithm of Jonker & Volgenant (1987) in the form of
Crouse, "On implementing 2D rectangular assignment algorithms", *IEEE Trans. Aerospace and
Electronic Systems* 52(4), 2016, which is also what :func:`scipy.optimize.linear_sum_assignment`
runs; it is written here for numba so that a tracker solves the problems of hundreds of egos in
one compiled call.  Each row is added by one Dijkstra search for the cheapest augmenting path on
the reduced costs :math:`C_{ij} - u_i - v_j`, after which the dual variables are updated
(Crouse 2016, Algorithm 1 with the updates of §IV).

:func:`gnn` is the GNN data association of Blackman & Popoli, *Design and Analysis of Modern
Tracking Systems* (1999), §6.5: rows (tracks) are assigned to columns (detections, or another
sensor's tracks) by minimising the total squared Mahalanobis distance :math:`d^2_{ij}`, where a
pair outside the chi-square gate, :math:`d^2_{ij} \ge \gamma`, is forbidden and every row may
instead be left unassigned at the cost :math:`\gamma` of a missed detection.  The cost matrix is
the one of Stone Soup's ``GNNWith2DAssignment`` with a ``DistanceHypothesiser`` whose
``missed_distance`` is :math:`\gamma`:

.. math::

    C = \left[\; D \;\middle|\; \operatorname{diag}(\gamma, \ldots, \gamma)
        \text{ with } \infty \text{ off the diagonal} \;\right],
    \qquad D_{ij} = \begin{cases} d^2_{ij} & d^2_{ij} < \gamma \\ \infty & \text{else.}
    \end{cases}
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def assign(
    cost, n_r, n_c, col4row, row4col, u, v, shortest, path, remaining, sr, sc
):  # pragma: no cover - compiled
    """Solve the assignment of the leading ``(n_r, n_c)`` block of ``cost`` (``n_r <= n_c``).

    Writes ``col4row[:n_r]`` (the column of each row) and ``row4col[:n_c]`` (the row of each
    column, -1 if none); returns False if no assignment of finite cost exists.  ``u (n_r,)``,
    ``v``, ``shortest``, ``path``, ``remaining``, ``sc (n_c,)`` and ``sr (n_r,)`` are scratch
    (at least that long), so a caller solving many problems allocates once.
    """
    for i in range(n_r):
        u[i] = 0.0
        col4row[i] = -1
    for j in range(n_c):
        v[j] = 0.0
        row4col[j] = -1
        path[j] = -1
    for cur in range(n_r):
        for j in range(n_c):
            remaining[j] = n_c - j - 1
            shortest[j] = np.inf
            sc[j] = False
        for i in range(n_r):
            sr[i] = False
        n_rem, min_val, i, sink = n_c, 0.0, cur, -1
        while sink == -1:  # Dijkstra on the reduced costs
            index, lowest = -1, np.inf
            sr[i] = True
            for it in range(n_rem):
                j = remaining[it]
                reduced = min_val + cost[i, j] - u[i] - v[j]
                if reduced < shortest[j]:
                    path[j] = i
                    shortest[j] = reduced
                if shortest[j] < lowest or (shortest[j] == lowest and row4col[j] == -1):
                    lowest = shortest[j]
                    index = it
            min_val = lowest
            if min_val == np.inf:
                return False
            j = remaining[index]
            if row4col[j] == -1:
                sink = j
            else:
                i = row4col[j]
            sc[j] = True
            n_rem -= 1
            remaining[index] = remaining[n_rem]
        u[cur] += min_val  # dual update
        for r in range(n_r):
            if sr[r] and r != cur:
                u[r] += min_val - shortest[col4row[r]]
        for j in range(n_c):
            if sc[j]:
                v[j] -= min_val - shortest[j]
        j = sink  # augment along the path
        while True:
            r = path[j]
            row4col[j] = r
            previous = col4row[r]
            col4row[r] = j
            j = previous
            if r == cur:
                break
    return True


@njit(cache=True)
def scratch_arrays(rows, cols):  # pragma: no cover - compiled
    """Work arrays of :func:`gnn` for problems of up to ``rows`` rows and ``cols`` columns,
    as it takes them (a kernel that solves problems on several threads makes one set each)."""
    width = cols + rows
    return (
        np.empty((rows, width)), np.empty(rows, np.int64), np.empty(width, np.int64),
        np.empty(rows), np.empty(width), np.empty(width), np.empty(width, np.int64),
        np.empty(width, np.int64), np.empty(rows, np.bool_), np.empty(width, np.bool_),
        np.empty(rows + width, np.int64), np.empty(rows, np.int64), np.empty(rows, np.int64),
        np.empty(rows, np.int64), np.empty(width, np.int64), np.empty(rows, np.int64),
        np.empty(width, np.int64),
    )  # fmt: skip


class Scratch:
    """Work arrays of :func:`gnn` for problems of up to ``rows`` rows and ``cols`` columns
    (:func:`scratch_arrays`): the cost matrix, the solver's (``col4row``, ``row4col``, the
    duals ``u``, ``v``, ``shortest``, ``path``, ``remaining``, ``sr``, ``sc``) and the gate's
    parts (a union-find ``root``, per-part lists ``head_r``, ``head_c``, ``next_r``,
    ``next_c``, and a part's rows and columns ``part_r``, ``part_c``)."""

    _NAMES = ("cost", "col4row", "row4col", "u", "v", "shortest", "path", "remaining", "sr",
              "sc", "root", "head_r", "head_c", "next_r", "next_c", "part_r", "part_c")  # fmt: skip

    def __init__(self, rows: int, cols: int) -> None:
        self._arrays = scratch_arrays(int(rows), int(cols))
        for name, array in zip(self._NAMES, self._arrays, strict=True):
            setattr(self, name, array)

    def arrays(self) -> tuple:
        """The arrays as :func:`gnn` takes them."""
        return self._arrays


@njit(cache=True)
def gnn(d2, n_r, n_c, gate, out, scratch):  # pragma: no cover - compiled
    r"""GNN assignment of the leading ``(n_r, n_c)`` block of the squared distances ``d2``
    (module docstring): ``out[i]`` receives the column of row ``i`` or -1 (missed);
    ``scratch``: :meth:`Scratch.arrays`.

    The problem splits into the connected parts of the gate's bipartite graph (rows and
    columns joined by a pair inside the gate): outside its part a row's every cost is
    :math:`\infty`, so the optimal assignment is the union of the parts' optimal assignments,
    each solved alone by :func:`assign`.  A row without a gated pair is missed; a part of one
    row and one column is assigned at once (its distance is below the gate, the cost of a
    miss).  In traffic most parts are one track and its detection, so this keeps the cost
    near linear in the tracks."""
    cost, col4row, row4col, u, v, shortest, path, remaining, sr, sc = scratch[:10]
    root, head_r, head_c, next_r, next_c, part_r, part_c = scratch[10:]
    for i in range(n_r + n_c):
        root[i] = i
    for i in range(n_r):
        out[i] = -1
        head_r[i], head_c[i] = -1, -1
        for j in range(n_c):
            if d2[i, j] < gate:
                a, b = _find_root(root, i), _find_root(root, n_r + j)
                if a != b:  # a part's root is its lowest node: its lowest row
                    root[max(a, b)] = min(a, b)
    for i in range(n_r - 1, -1, -1):  # each part's rows and columns, in increasing order
        top = _find_root(root, i)
        next_r[i], head_r[top] = head_r[top], i
    for j in range(n_c - 1, -1, -1):
        top = _find_root(root, n_r + j)
        if top < n_r:  # a column in no part has itself for root
            next_c[j], head_c[top] = head_c[top], j
    for top in range(n_r):
        if root[top] != top or head_c[top] < 0:  # not a part's root, or a row gating nothing
            continue
        m_r, i = 0, head_r[top]
        while i >= 0:
            part_r[m_r], m_r, i = i, m_r + 1, next_r[i]
        m_c, j = 0, head_c[top]
        while j >= 0:
            part_c[m_c], m_c, j = j, m_c + 1, next_c[j]
        if m_r == 1 and m_c == 1:
            out[top] = part_c[0]
            continue
        width = m_c + m_r
        for a in range(m_r):
            for b in range(m_c):
                d = d2[part_r[a], part_c[b]]
                cost[a, b] = d if d < gate else np.inf
            for b in range(m_c, width):
                cost[a, b] = gate if b - m_c == a else np.inf
        assign(cost, m_r, width, col4row, row4col, u, v, shortest, path, remaining, sr, sc)
        for a in range(m_r):
            if col4row[a] < m_c:
                out[part_r[a]] = part_c[col4row[a]]


@njit(cache=True, inline="always")
def _find_root(root, i):  # pragma: no cover - compiled
    """The root of node ``i`` in the union-find forest ``root``, halving the path."""
    while root[i] != i:
        root[i] = root[root[i]]
        i = root[i]
    return i
