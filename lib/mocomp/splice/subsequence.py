"""Open-begin/open-end (subsequence) DTW: where in a long body take does a
short hand recording belong? (issue #19 item 9; an extension of
dissertation ch. 6.1, whose eq. 6.1-6.3 always stretch the whole hand clip
over the whole body clip.)

The hand recording (``m`` frames, the *query*) is matched completely; the body
recording (``n`` frames, the *reference*) only over an interval
``start..end`` chosen by the alignment. The recurrence is the classic
asymmetric step pattern of subsequence DTW (Sakoe & Chiba's asymmetric
``P = 0``; dtw-python's ``asymmetric`` with ``open_begin=True,
open_end=True``): every hand frame ``j`` is matched to exactly one body frame,
which advances by 0, 1 or 2 frames per hand frame,

    G(j, i) = D(i, j) + min(G(j-1, i), G(j-1, i-1), G(j-1, i-2)),
    G(0, i) = D(i, 0)                       (open begin: any start frame),
    end = argmin_i G(m-1, i)                (open end),

so the total cost sums exactly ``m`` local costs whatever the interval's
length (symmetric1, eq. 6.2, cannot do this: its cost grows with the number of
body frames covered, so an open end would favour short intervals; dtw-python
refuses open-begin for it for that reason). The hand may play at most twice
slower than recorded inside the interval (slope 2) and arbitrarily faster.
Ties are broken as dtw-python breaks them (the first minimum in the order
same body frame, one back, two back; the first end frame), so cost, end frame
and path agree with it on the same cost matrix (tested).

The interval found is then aligned by the two-stage method proper
(:func:`~mocomp.splice.align.align_hands` with ``SpliceConfig.subsequence``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core._compiled import njit
from ..errors import AlignmentError

__all__ = ["SubsequenceResult", "subsequence_dtw"]


@dataclass(frozen=True, eq=False)
class SubsequenceResult:
    """The best match of the whole query (hand) inside the reference (body).

    Attributes
    ----------
    start, end: first and last body frame of the matched interval (inclusive).
    cost: ``G(m-1, end)``, the sum of the ``m`` local costs on the path.
    path: ``(m, 2)`` int64 ``(body frame, hand frame)``, one row per hand frame.
    end_costs: ``(n,)`` best cost of a match ending at each body frame (``inf``
        where none can end).
    n, m: lengths.
    """

    start: int
    end: int
    cost: float
    path: np.ndarray
    end_costs: np.ndarray
    n: int
    m: int

    @property
    def normalized_cost(self) -> float:
        """Cost per hand frame (dtw-python's ``normalizedDistance`` for ``asymmetric``)."""
        return self.cost / self.m

    @property
    def interval(self) -> tuple[int, int]:
        return self.start, self.end

    def to_dict(self) -> dict:
        return {"start": self.start, "end": self.end, "frames": self.end - self.start + 1,
                "cost": float(self.cost), "cost_per_hand_frame": float(self.normalized_cost)}


@njit
def _subsequence_kernel(C, G, step):  # pragma: no cover - compiled
    """The recurrence of the module docstring: ``G (m, n)`` cumulative costs and
    ``step (m, n)`` body frames moved back (0, 1, 2; the first minimum in that order)."""
    n, m = C.shape
    inf = np.inf
    for i in range(n):
        G[0, i] = C[i, 0]
        step[0, i] = 0
    for j in range(1, m):
        for i in range(n):
            best = G[j - 1, i]
            k = 0
            if i >= 1 and G[j - 1, i - 1] < best:
                best = G[j - 1, i - 1]
                k = 1
            if i >= 2 and G[j - 1, i - 2] < best:
                best = G[j - 1, i - 2]
                k = 2
            G[j, i] = C[i, j] + best if best < inf else inf
            step[j, i] = k


def subsequence_dtw(cost: np.ndarray) -> SubsequenceResult:
    """Open-begin, open-end DTW on a dense cost matrix ``cost (n, m)``: rows the
    body (reference), columns the hand (query, matched completely). See the
    module docstring for the recurrence. A compiled loop over the cells,
    ``O(n m)`` time and memory."""
    C = np.ascontiguousarray(cost, dtype=np.float64)
    if C.ndim != 2 or C.shape[0] < 1 or C.shape[1] < 1:
        raise AlignmentError(f"subsequence DTW needs an (n, m) cost matrix, got shape {C.shape}")
    if not np.all(np.isfinite(C)):
        i, j = np.argwhere(~np.isfinite(C))[0]
        raise AlignmentError(f"local cost is {C[i, j]} at cell ({i}, {j}); costs must be finite")
    n, m = C.shape
    G = np.empty((m, n))
    step = np.empty((m, n), dtype=np.int8)
    _subsequence_kernel(C, G, step)
    end = int(np.argmin(G[m - 1]))  # the first minimum, as dtw-python's nanargmin
    path = np.empty((m, 2), dtype=np.int64)
    i = end
    for j in range(m - 1, -1, -1):
        path[j] = (i, j)
        i -= int(step[j, i])
    ends = G[m - 1].copy()
    for a in (path, ends):
        a.setflags(write=False)
    return SubsequenceResult(int(path[0, 0]), end, float(G[m - 1, end]), path, ends, n, m)
