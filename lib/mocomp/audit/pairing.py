"""Which flight of one motion is which flight of another (``audit(..., against=...)`` comparisons).

Pairing by index is wrong as soon as one motion has an airborne run the other lacks: CMU 90_08 has
a one-frame "flight" at frame 0 (a contact-detector flicker), so its side flip is its third
airborne run while an edit of it, which lost the flicker, has it second. :func:`pair_flights`:

1. drops the *spurious* runs of both motions (shorter than ``min_airborne_frames`` frames or
   ``min_airborne_time``; :class:`~mocomp.audit.AuditThresholds`): they are still reported, never
   paired;
2. puts each remaining flight on a common time axis: seconds when the two clips last the same
   (within 1.5 frames), else time normalised by each clip's duration (a retimed output: a flip
   played k times slower is longer, and so is the whole clip);
3. pairs the flights **by order** when both motions have the same number and every pair overlaps on
   that axis (each interval padded by half its length plus 0.1 s, or 0.02 of the clip when
   normalised, so a retimed flight that moved a little still overlaps its original);
4. otherwise by **best overlap**: an order-preserving alignment (dynamic programming, like a
   sequence alignment) maximising the summed overlap ratio (intersection over union of the padded
   intervals); a flight with no overlapping partner stays unpaired.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["FlightPairing", "pair_flights", "interval_overlap"]


@dataclass(frozen=True)
class FlightPairing:
    """``pairs``: ``(this flight index, other flight index)`` (0-based, indices of each report's
    ``flights``); ``method``: ``"order"``, ``"overlap"`` or ``"none"`` (no flight on a side);
    ``time_base``: ``"seconds"`` or ``"normalised"``; ``unpaired_this`` / ``unpaired_other``: the
    non-spurious flights left without a partner; ``spurious_this`` / ``spurious_other``: the runs
    left out as spurious."""

    pairs: tuple[tuple[int, int], ...]
    method: str
    time_base: str
    unpaired_this: tuple[int, ...] = ()
    unpaired_other: tuple[int, ...] = ()
    spurious_this: tuple[int, ...] = ()
    spurious_other: tuple[int, ...] = ()

    def other_of(self, i: int) -> int | None:
        for a, b in self.pairs:
            if a == i:
                return b
        return None

    def text(self) -> str:
        p = ", ".join(f"{a + 1}<->{b + 1}" for a, b in self.pairs) or "none"
        extra = []
        if self.spurious_this or self.spurious_other:
            extra.append("spurious runs left out: this " + (", ".join(str(i + 1) for i in self.spurious_this) or "-")
                         + "; against " + (", ".join(str(i + 1) for i in self.spurious_other) or "-"))
        if self.unpaired_this or self.unpaired_other:
            extra.append("unpaired: this " + (", ".join(str(i + 1) for i in self.unpaired_this) or "-")
                         + "; against " + (", ".join(str(i + 1) for i in self.unpaired_other) or "-"))
        return f"flights paired by {self.method} ({self.time_base} time): {p}" + ("; " + "; ".join(extra) if extra else "")

    def to_dict(self) -> dict:
        return {"pairs": [[a + 1, b + 1] for a, b in self.pairs], "method": self.method, "time_base": self.time_base,
                "unpaired_this": [i + 1 for i in self.unpaired_this],
                "unpaired_against": [i + 1 for i in self.unpaired_other],
                "spurious_this": [i + 1 for i in self.spurious_this],
                "spurious_against": [i + 1 for i in self.spurious_other]}


def interval_overlap(x: tuple[float, float], y: tuple[float, float], pad: float) -> float:
    """Intersection over union of ``x`` and ``y``, each widened by half its length plus ``pad`` on
    both sides (0 when they do not meet)."""
    def widen(r):
        h = 0.5 * (r[1] - r[0]) + pad
        return r[0] - h, r[1] + h

    a, b = widen(x), widen(y)
    inter = min(a[1], b[1]) - max(a[0], b[0])
    if inter <= 0:
        return 0.0
    return float(inter / (max(a[1], b[1]) - min(a[0], b[0])))


def _is_flight(f) -> bool:
    return getattr(f, "kind", "free") != "spurious"


def pair_flights(this, other) -> FlightPairing:
    """Pair the flights of two :class:`~mocomp.audit.AuditReport` s (module docstring)."""
    ti = [f.index for f in this.flights if _is_flight(f)]
    oi = [f.index for f in other.flights if _is_flight(f)]
    sp_t = tuple(f.index for f in this.flights if not _is_flight(f))
    sp_o = tuple(f.index for f in other.flights if not _is_flight(f))
    dt, do = this.n_frames / this.fps, other.n_frames / other.fps
    if abs(dt - do) <= 1.5 * max(1.0 / this.fps, 1.0 / other.fps):
        base, st, so, pad = "seconds", 1.0 / this.fps, 1.0 / other.fps, 0.1
    else:
        base, st, so, pad = "normalised", 1.0 / (this.fps * dt), 1.0 / (other.fps * do), 0.02
    fr_t = {f.index: f.frames for f in this.flights}
    fr_o = {f.index: f.frames for f in other.flights}
    it = [(fr_t[i][0] * st, fr_t[i][1] * st) for i in ti]
    io = [(fr_o[j][0] * so, fr_o[j][1] * so) for j in oi]
    if not ti or not oi:
        return FlightPairing((), "none", base, tuple(ti), tuple(oi), sp_t, sp_o)
    S = np.array([[interval_overlap(x, y, pad) for y in io] for x in it])
    if len(ti) == len(oi) and np.all(np.diag(S) > 0):
        return FlightPairing(tuple(zip(ti, oi)), "order", base, (), (), sp_t, sp_o)
    n, m = S.shape
    D = np.zeros((n + 1, m + 1))
    for i in range(1, n + 1):
        for j in range(1, m + 1):
            best = max(D[i - 1, j], D[i, j - 1])
            if S[i - 1, j - 1] > 0:
                best = max(best, D[i - 1, j - 1] + S[i - 1, j - 1])
            D[i, j] = best
    pairs = []
    i, j = n, m
    while i > 0 and j > 0:
        if S[i - 1, j - 1] > 0 and np.isclose(D[i, j], D[i - 1, j - 1] + S[i - 1, j - 1]):
            pairs.append((ti[i - 1], oi[j - 1]))
            i, j = i - 1, j - 1
        elif D[i - 1, j] >= D[i, j - 1]:
            i -= 1
        else:
            j -= 1
    pairs.reverse()
    pt = {a for a, _ in pairs}
    po = {b for _, b in pairs}
    return FlightPairing(tuple(pairs), "overlap", base, tuple(i for i in ti if i not in pt),
                         tuple(j for j in oi if j not in po), sp_t, sp_o)
