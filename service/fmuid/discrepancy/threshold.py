"""Null distributions of threshold candidates' statistics: a level fitted over a continuum.

A saturation or a dead zone has no effect at its off level and an effect at every level the
signals reach; its full fit maximises the likelihood over that continuum of levels. Under the
base model the level is not identified (Davies' problem), and the chi-bar-square null of one
probe direction (:func:`~.scan.null_p_value`) is far too liberal: the statistic is the supremum
of a process over the levels. Each threshold candidate carries the null of that supremum, drawn
with the projected noise ``x = (I - P) e`` (``P`` the projection on the base fit's
sensitivities, ``e`` white) jointly with every other candidate's score in the scan's min-P
(:func:`.decide.calibrate`).

**An output clipped at a level** (:class:`ClipNull`). The recorded output is ``min(y, L)``.
Linearised about the base fit, the clipped samples ``C = {y > L}`` no longer depend on the
base parameters (their prediction is the level itself) while the others do. With ``w`` the
weights ``1/sigma``, ``B`` an orthonormal basis of the weighted sensitivities and ``x`` the
weighted residuals (``B^T x = 0``), the chi2 drop of the exact clipped linear model at a level
``L`` is::

    sum_C x^2 - sum_C (x + w (y - L))^2 + b^T (I - B_C^T B_C)^+ b,    b = B_C^T x_C

(the last term: the base parameters fitted on the samples left unclipped). Between two
successive predicted values the clipped set is fixed and the drop is a concave quadratic in
``L``, maximised in closed form; the supremum runs over every such piece from the largest
prediction down to the level's lower bound (every piece up to :data:`EXACT_PIECES` clipped
samples, then pieces each clipping at least :data:`PIECE_RATIO` times as many, where one more
sample changes the drop little). A lower limit is the same on ``-y``. No simulation is needed.

**An input clipped or cut** (:class:`LevelsNull`): each level needs a simulation, so the
supremum runs over the screened levels' projected directions ``u_g``, each with a free size
(a chi-bar-square per level): ``max_g max(x . u_g / |u_g|, 0)^2``.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
from scipy import sparse

MOVE = 4.0
"""Samples predicted below the level's bound by less than this many standard deviations of
the base fit's prediction there may still be clipped (the fit moves them above the level)."""

FREE = 1e-8
"""Floor of the eigenvalues of ``I - B_C^T B_C``: a direction of the base parameters that only
the clipped samples see moves at (almost) no cost; the scores never point along it."""

EXACT_PIECES = 64
"""Clipped-sample counts up to which every piece of the level's range is evaluated."""

PIECE_RATIO = 1.03
"""Past :data:`EXACT_PIECES`, each evaluated piece clips at least this many times more."""

BATCH = 1000
"""Null draws per batch (memory: draws x clipped samples x sensitivities)."""


def _ends(y: np.ndarray, reached: np.ndarray) -> np.ndarray:
    """Clipped counts at which the pieces end, thinned past :data:`EXACT_PIECES`.

    Every distinct value down to the last one a level in range can reach (``reached``).
    """
    above = int(np.flatnonzero(reached)[-1]) + 1 if reached.any() else 0
    distinct = [k for k in range(1, above + 1) if k == len(y) or y[k] < y[k - 1]]
    if above and (not distinct or distinct[-1] != above):
        distinct.append(above)
    kept: list[int] = []
    for k in distinct:
        if k <= EXACT_PIECES or not kept or k >= PIECE_RATIO * kept[-1] or k == distinct[-1]:
            kept.append(k)
    return np.asarray(kept, dtype=int)


SUBSETS = tuple(
    (list(a), [i for i in range(3) if i not in a])
    for size in (1, 2, 3)
    for a in itertools.combinations(range(3), size)
)
"""Active sets of the three edge constraints, each with the constraints left inactive."""


def _active_set(v: np.ndarray, coupling: np.ndarray, inverses: np.ndarray) -> np.ndarray:
    """Rise of chi2 when linear constraints violated by ``v`` (constraints x cases) hold.

    The least-squares projection onto ``c_i . z <= 0`` in the metric ``M`` of the unconstrained
    fit, ``coupling[m] = C M^-1 C^T`` of each case (``inverses``: the pseudo-inverse of its
    block of each of :data:`SUBSETS`): the active set whose multipliers are positive and whose
    projection satisfies the rest (the convex problem's unique solution).
    """
    out = np.zeros(v.shape[1])
    done = np.all(v <= 0, axis=0)
    for (active, rest), inverse in zip(SUBSETS, inverses):
        size = len(active)
        lam = np.einsum("mij,jm->im", inverse[:, :size, :size], v[active])
        ok = np.all(lam >= -1e-12, axis=0) & ~done
        if rest:
            block = coupling[:, rest][:, :, active]
            ok &= np.all(v[rest] - np.einsum("mij,jm->im", block, lam) <= 1e-12, axis=0)
        out = np.where(ok, np.sum(lam * v[active], axis=0), out)
        done |= ok
    return out


def _inverses(coupling: np.ndarray) -> np.ndarray:
    """Pseudo-inverse of each subset's block of ``coupling`` (subsets x pieces x 3 x 3)."""
    out = np.zeros((len(SUBSETS), *coupling.shape))
    for i, (active, _) in enumerate(SUBSETS):
        size = len(active)
        out[i, :, :size, :size] = np.linalg.pinv(coupling[:, active][:, :, active], hermitian=True)
    return out


@dataclass(frozen=True)
class ClipNull:
    """Null of the chi2 drop of an output clipped at a fitted level (see the module docstring).

    Attributes
    ----------
    rows
        Indices in the residual vector of the samples a level in range can clip, by signed
        prediction, largest first.
    sums
        Sparse ``(pieces * (2 + rank)) x rows``: a piece's sums of ``w y x``, ``w x`` and
        ``B x`` over the samples it adds to the clipped set (``y`` the signed prediction
        minus its largest value).
    shift
        ``sums @ B[rows]``: the same sums of the basis (``x = e - B B^T e``).
    constants
        Per piece, the clipped samples' ``sum w^2``, ``sum w^2 y`` and ``sum w^2 y^2``.
    low, high
        Each piece's range of the shifted signed level: the prediction of its highest
        unclipped sample (the level's bound when every sample is clipped) and of its lowest
        clipped one. The last piece may reach below the bound, down to its highest unclipped
        sample (a slightly larger supremum: conservative).
    factor
        ``F`` with ``F^T F = (I - B_C^T B_C)^+`` of each piece.
    reach
        ``(I - B_C^T B_C)^+ a`` of each piece's two edge samples (``a = B_i / w_i``: how the
        base parameters move their prediction; zero for the bound).
    coupling, inverses
        ``c_i^T M^-1 c_j`` of the three edge constraints (the lowest clipped sample, the highest
        unclipped one, the level's bound) in the metric ``M`` of the clipped fit, and the
        pseudo-inverses of its blocks (:func:`_active_set`).
    basis
        Orthonormal basis of the base fit's weighted sensitivities (all rows).
    sign
        +1 for an upper limit, -1 for a lower one (the signs of ``y`` and ``x`` flipped).

    """

    rows: np.ndarray
    sums: sparse.csr_matrix
    shift: np.ndarray
    constants: np.ndarray
    bounds: np.ndarray
    factor: np.ndarray
    reach: np.ndarray
    coupling: np.ndarray
    inverses: np.ndarray
    basis: np.ndarray
    sign: float

    @classmethod
    def build(
        cls,
        rows: np.ndarray,
        predicted: np.ndarray,
        weight: np.ndarray,
        basis: np.ndarray,
        floor: float,
        upper: bool = True,
    ) -> ClipNull:
        """Return the null of one output's limit.

        Parameters
        ----------
        rows
            The output's indices in the residual vector.
        predicted, weight
            The base fit's prediction and ``1/sigma`` at those rows.
        basis
            Orthonormal basis of the weighted sensitivities (``n_data x rank``).
        floor
            The level's bound inside the range (the lowest upper limit, or the highest lower
            limit), in the output's units.
        upper
            An upper limit (else a lower one).

        """
        sign = 1.0 if upper else -1.0
        y = sign * np.asarray(predicted, dtype=float)
        order = np.argsort(-y, kind="stable")
        y, rows, w = y[order], np.asarray(rows)[order], np.asarray(weight, dtype=float)[order]
        a = basis[rows] / w[:, None]
        spread = np.linalg.norm(a, axis=1)
        ends = _ends(y, y > sign * floor - MOVE * spread)
        top = float(y[0]) if y.size else 0.0
        y, bottom = y - top, sign * floor - top
        k = ends - 1
        a = np.vstack([a, np.zeros((1, basis.shape[1]))])
        nxt = np.minimum(ends, len(y))
        high, low = y[k], np.append(y, bottom)[nxt]
        used = int(ends[-1]) if ends.size else 0
        rows, y, w = rows[:used], y[:used], w[:used]
        b_rows = basis[rows]
        columns = np.column_stack([w * y, w, b_rows])
        width = columns.shape[1]
        piece = np.searchsorted(ends, np.arange(used), side="right")
        sums = sparse.coo_matrix(
            (
                columns.ravel(),
                (
                    ((piece * width)[:, None] + np.arange(width)).ravel(),
                    np.repeat(np.arange(used), width),
                ),
            ),
            shape=(len(ends) * width, used),
        ).tocsr()
        constants = np.stack([np.cumsum(w**2 * y**j)[k] for j in range(3)])
        outer = np.cumsum(b_rows[:, :, None] * b_rows[:, None, :], axis=0)[k]
        values, vectors = np.linalg.eigh(np.eye(basis.shape[1])[None] - outer)
        scale = 1.0 / np.sqrt(np.maximum(values, FREE))
        factor = np.ascontiguousarray((vectors * scale[:, None, :]).transpose(0, 2, 1))
        edge = np.stack([-a[k], a[nxt], np.zeros_like(a[k])], axis=1)  # (pieces, 3, rank)
        projected = np.einsum("kqp,kcp->kcq", factor, edge)
        reach = np.einsum("kqp,kcq->kcp", factor, projected)
        coupling = np.einsum("kcq,kdq->kcd", projected, projected)
        side = np.array([1.0, -1.0, -1.0])
        coupling += np.outer(side, side) / constants[0][:, None, None]
        bounds = np.stack([high, -low, -np.full_like(low, bottom)])
        return cls(
            rows,
            sums,
            sums @ b_rows,
            constants,
            bounds,
            factor,
            reach,
            coupling,
            _inverses(coupling),
            basis,
            sign,
        )

    @property
    def pieces(self) -> int:
        """Number of evaluated pieces of the level's range."""
        return self.bounds.shape[1]

    def statistics(self, e: np.ndarray) -> np.ndarray:
        """Supremum of the drop over the levels for white noise draws ``e`` (draws x n_data)."""
        if not self.pieces:
            return np.zeros(e.shape[0])
        g = e @ self.basis
        totals = self.sums @ np.ascontiguousarray(e[:, self.rows].T) - self.shift @ g.T
        return self._supremum(self.sign * totals)

    def observed(self, r0: np.ndarray) -> float:
        """Supremum of the linearised drop for weighted residuals ``r0`` (``B^T r0 = 0``)."""
        if not self.pieces:
            return 0.0
        return float(self._supremum(self.sign * (self.sums @ r0[self.rows])[:, None])[0])

    def _supremum(self, totals: np.ndarray) -> np.ndarray:
        """Supremum over the pieces from their sums (``(pieces * (2 + rank)) x draws``)."""
        sums = np.cumsum(totals.reshape(self.pieces, -1, totals.shape[1]), axis=0)
        s1, s2, b = sums[:, 0], sums[:, 1], sums[:, 2:]
        w2, wy, wy2 = (c[:, None] for c in self.constants)
        level = (s2 + wy) / w2
        free = np.sum(np.einsum("kqp,kpd->kqd", self.factor, b) ** 2, axis=1)
        drop = -2 * s1 - wy2 + 2 * level * (s2 + wy) - level**2 * w2 + free
        moved = -np.einsum("kcp,kpd->ckd", self.reach, b)
        violation = self.side[:, None, None] * level[None] + moved - self.bounds[:, :, None]
        feasible = np.all(violation <= 0, axis=0)  # the unconstrained fit holds there
        best = np.where(feasible, drop, 0.0).max(axis=0)
        penalty = np.full(drop.shape, np.nan)
        for i in range(3):  # one constraint active: a closed form
            lam = violation[i] / self.coupling[:, i, i, None]
            others = [j for j in range(3) if j != i]
            rest = violation[others] - self.coupling[:, others, i].T[:, :, None] * lam
            single = (violation[i] > 0) & np.all(rest <= 1e-12, axis=0)
            penalty = np.where(single & np.isnan(penalty), violation[i] * lam, penalty)
        best = np.maximum(best, np.where(np.isnan(penalty), -np.inf, drop - penalty).max(axis=0))
        piece, draw = np.nonzero(~feasible & np.isnan(penalty) & (drop > best))
        if piece.size:  # two or three active
            value = drop[piece, draw] - _active_set(
                violation[:, piece, draw], self.coupling[piece], self.inverses[:, piece]
            )
            np.maximum.at(best, draw, value)
        return np.maximum(best, 0.0)

    @property
    def side(self) -> np.ndarray:
        """Sign of the level in each edge constraint (lowest clipped, highest unclipped, bound)."""
        return np.array([1.0, -1.0, -1.0])


@dataclass(frozen=True)
class LevelsNull:
    """Null of an input threshold's statistic: the supremum over its screened levels.

    Attributes
    ----------
    directions
        Projected directions ``u_g`` of the screened levels (columns, unit length).

    """

    directions: np.ndarray

    def statistics(self, e: np.ndarray) -> np.ndarray:
        """``max_g max(e . u_g, 0)^2`` for white noise draws ``e`` (draws x n_data)."""
        if not self.directions.shape[1]:
            return np.zeros(e.shape[0])
        return np.max(np.maximum(e @ self.directions, 0.0), axis=1) ** 2


ThresholdNull = ClipNull | LevelsNull
"""The null of a threshold candidate's statistic."""


def unit_columns(u: np.ndarray) -> np.ndarray:
    """Columns of ``u`` scaled to unit length (zero columns dropped)."""
    norms = np.linalg.norm(u, axis=0)
    keep = norms > 1e-12 * max(float(norms.max(initial=0.0)), 1e-300)
    return u[:, keep] / norms[keep]
