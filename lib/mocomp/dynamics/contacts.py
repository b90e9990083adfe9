"""Ground contacts of end effectors and airborne (flight) intervals.

Per effector (feet, toes, hands), a frame is in contact when the effector is
near a support level *and* slow (the constraint method the flips paper adopts
from Liu & Popovic 2002, section 4.1). Heights are relative to the clip's own
ground (unknown floor offsets work), and the support levels are found per
effector from the clip itself:

* a *rest* is a run of at least ``rest_time`` in which the effector moves slower
  than ``rest_speed`` while being (within ``max_clearance``) the lowest effector
  of the body -- a foot standing on a box, not a hand hanging at the side or a
  foot slowing at the apex of a jump;
* the rests are clustered by the floor under the body (the mean height of the
  lowest effector during the rest; a new level where the sorted floors jump by
  more than ``height_tol``), so a foot resting on tiptoe and flat on the same
  floor is one level; the effector's level on each floor is the 1st percentile
  of its heights during those rests, and floors on which the effector rests
  within ``height_tol`` of the same height are merged into one level;
* one level (level ground): the effector touches while it is within
  ``height_tol`` of its resting level, the 1st percentile of its height in the
  clip (the behaviour of a single floor, unchanged);
* two or more levels (take-off from a box, landing on a step, ...): the effector
  touches level ``k`` on the runs of frames within ``height_tol`` of that level
  that contain a rest at it (so a foot rising through the height of the box it
  will land on does not touch it in mid-air).

Effectors that never come within ``max_clearance`` of the ground
(hands in a walk) are never in contact. The flips method refines flight
detection with the momentum pattern; :func:`airborne_intervals` is the plain
geometric answer it starts from.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core.rotations import quat_apply
from ..errors import MotionFormatError
from ..core.kinematics import central_difference, gaussian_smooth

__all__ = ["ContactResult", "detect_contacts", "airborne_intervals", "default_effectors", "effector_positions",
           "label_intervals"]


@dataclass(frozen=True, eq=False)
class ContactResult:
    """Contact labels per end effector.

    Attributes
    ----------
    effectors: ``(E,)`` names (``"foot_l"``, ``"toe_l"``, ``"hand_l"``, ... or the joints given).
    labels: ``(T, E)`` bool, effector planted: near a support level *and* slow.
    touching: ``(T, E)`` bool, effector near a support level (height only; a rolling
        toe or a sliding foot touches without being planted).
    ground_y: m, the clip's ground level (low percentile of the lowest effector height).
    intervals: effector name -> list of half-open ``(start, stop)`` contact frame ranges.
    positions: ``(T, E, 3)`` m, effector world positions.
    heights: ``(T, E)`` m above ``ground_y``.
    speeds: ``(T, E)`` m/s.
    levels: ``(E,)`` m above ``ground_y``: each effector's lowest support level (one level: the
        1st percentile of its height).
    support_levels: effector name -> tuple of its support levels, m above ``ground_y``
        (one entry on level ground; empty for an effector that never rests low).
    contact_levels: ``(T, E)`` m above ``ground_y``, the level each effector touches
        (NaN where it touches none).
    height_tol, speed_tol: thresholds used (m, m/s).
    effector_joints: ``(E,)`` joint index each effector point rides on.
    effector_offsets: ``(E, 3)`` m, the point in that joint's frame.
    fps: frames per second of the motion.
    """

    effectors: tuple[str, ...]
    labels: np.ndarray
    touching: np.ndarray
    ground_y: float
    intervals: dict
    positions: np.ndarray
    heights: np.ndarray
    speeds: np.ndarray
    levels: np.ndarray
    height_tol: float
    speed_tol: float
    effector_joints: np.ndarray
    effector_offsets: np.ndarray
    fps: float = 0.0
    notes: tuple[str, ...] = field(default=())
    support_levels: dict = field(default_factory=dict)
    contact_levels: np.ndarray | None = None

    @property
    def any_contact(self) -> np.ndarray:
        """``(T,)`` bool, at least one effector planted."""
        return self.labels.any(axis=1)

    @property
    def any_touching(self) -> np.ndarray:
        """``(T,)`` bool, at least one effector touching the ground."""
        return self.touching.any(axis=1)

    def contact_points(self) -> tuple[np.ndarray, np.ndarray]:
        """``(positions (T, E, 3), labels (T, E))`` projected on the ground plane, for
        :func:`~mocomp.dynamics.zmp.support_polygon_distance` (only ``x``, ``z`` enter
        the support polygon)."""
        p = np.array(self.positions)
        p[..., 1] = self.ground_y
        return p, self.labels


def label_intervals(labels: np.ndarray) -> list[tuple[int, int]]:
    """Half-open ``(start, stop)`` runs of True in a 1-D bool array."""
    x = np.concatenate([[False], np.asarray(labels, dtype=bool), [False]])
    d = np.diff(x.astype(np.int8))
    starts = np.nonzero(d == 1)[0]
    stops = np.nonzero(d == -1)[0]
    return [(int(a), int(b)) for a, b in zip(starts, stops)]


def _drop_short(labels: np.ndarray, value: bool, min_frames: int) -> np.ndarray:
    """Flip runs of ``value`` shorter than ``min_frames`` (bounded on both sides) to ``not value``."""
    out = labels.copy()
    if min_frames <= 1:
        return out
    runs = label_intervals(out == value)
    for a, b in runs:
        if b - a < min_frames and a > 0 and b < len(out):
            out[a:b] = not value
    return out


def default_effectors(skeleton) -> dict[str, tuple[int, np.ndarray]]:
    """Feet (ankle joints), toe tips and hand ends from the skeleton's body-segment mapping:
    name -> (joint index, local offset in metres).

    A toe tip rides on the foot's descendant joint nearest to it (the toe joint,
    e.g. ``LeftToeBase``), so that it stays on the floor while the heel rises; a
    hand end rides on the hand's carrier joint.
    """
    from ..body.mapping import resolve_mapping

    rm = resolve_mapping(skeleton)
    rest = skeleton.rest_positions()
    parents = skeleton.parents
    out = {}
    # the mapping has resolved them already: the foot segment runs AJC -> TTIP, the hand WJC -> MET3
    for kind, seg_kind, ends in (("foot", "foot", rm.proximal), ("toe", "foot", rm.distal), ("hand", "hand", rm.distal)):
        for side in ("l", "r"):
            k = rm.segments.index(f"{seg_kind}_{side}")
            j = int(rm.carriers[k])
            p = ends[k]
            if kind == "toe":
                # j and its descendants (parents precede children: one pass over the parent array)
                below = np.zeros(len(parents), dtype=bool)
                below[j] = True
                for c in range(j + 1, len(parents)):
                    below[c] = below[parents[c]]
                desc = np.flatnonzero(below)
                j = int(desc[np.argmin(np.linalg.norm(rest[desc] - p, axis=1))])
            out[f"{kind}_{side}"] = (j, p - rest[j])
    return out


def _parse_effectors(skeleton, effectors) -> dict[str, tuple[int, np.ndarray]]:
    if effectors is None:
        return default_effectors(skeleton)
    if isinstance(effectors, dict):
        out = {}
        for name, spec in effectors.items():
            if isinstance(spec, str):
                spec = (spec, (0.0, 0.0, 0.0))
            jn, off = spec
            j = skeleton.index(jn) if isinstance(jn, str) else int(jn)
            out[name] = (j, np.asarray(off, dtype=float).reshape(3))
        return out
    out = {}
    for name in effectors:
        j = skeleton.find(name)
        if j is not None:
            out[name] = (j, np.zeros(3))
            continue
        es = [e for e in skeleton.end_sites if e.name == name]
        if not es:
            raise MotionFormatError(f"effector {name!r} is neither a joint nor an end site of the skeleton")
        out[name] = (es[0].parent, np.array(es[0].offset))
    return out


def effector_positions(motion, joints, offsets) -> np.ndarray:
    """``(T, E, 3)`` world positions of points fixed in joint frames."""
    P, G = motion.fk()
    joints = np.asarray(joints, dtype=int)
    return P[:, joints] + quat_apply(G[:, joints], np.asarray(offsets, dtype=float)[None])


def _rests(slow: np.ndarray, min_len: int) -> tuple[np.ndarray, np.ndarray]:
    """Starts and stops ``(R,)`` of the runs of True in ``slow`` ``(T,)`` at least ``min_len`` long."""
    x = np.concatenate([[False], slow, [False]]).astype(np.int8)
    d = np.diff(x)
    a = np.flatnonzero(d == 1)
    b = np.flatnonzero(d == -1)
    keep = (b - a) >= min_len
    return a[keep], b[keep]


def _support_levels(h, lowest, speed, rest_speed, min_len, height_tol, max_clearance):
    """Support levels of one effector: heights ``h`` ``(T,)``, the body's lowest effector
    height per frame ``lowest`` ``(T,)``, speeds ``(T,)``. Returns the levels ``(K,)``
    (sorted) and each rest ``(start, stop, level index)``."""
    a, b = _rests(speed <= rest_speed, min_len)
    if a.size == 0:
        return np.zeros(0), []
    # per rest: the floor under the body (mean height of its lowest effector), and how far
    # above that lowest point this effector sits
    n = b - a
    rid = np.repeat(np.arange(a.size), n)
    frames = np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n) + np.repeat(a, n)
    first = np.cumsum(n) - n
    hm = np.add.reduceat(lowest[frames], first) / n                 # mean floor during each rest
    above = np.add.reduceat(h[frames] - lowest[frames], first) / n
    ok = above <= max_clearance
    if not ok.any():
        return np.zeros(0), []
    a, b, hm = a[ok], b[ok], hm[ok]
    keep_f = ok[rid]
    frames, rid = frames[keep_f], np.cumsum(np.r_[0, np.diff(rid[keep_f]) != 0])
    order = np.argsort(hm)
    cluster_sorted = np.cumsum(np.r_[0, np.diff(hm[order]) > height_tol])
    cluster = np.empty_like(cluster_sorted)
    cluster[order] = cluster_sorted
    K = int(cluster.max()) + 1
    fc = cluster[rid]
    levels = np.array([np.percentile(h[frames[fc == k]], 1) for k in range(K)])
    # floors whose levels for this effector lie within height_tol are one level (the lowest
    # point of the body changed, e.g. toes lifted, but this effector rests where it did)
    o = np.argsort(levels)
    group_sorted = np.cumsum(np.r_[0, np.diff(levels[o]) > height_tol])
    group = np.empty_like(group_sorted)
    group[o] = group_sorted
    cluster = group[cluster]
    fc = cluster[rid]
    levels = np.array([np.percentile(h[frames[fc == k]], 1) for k in range(int(cluster.max()) + 1)])
    return levels, [(int(s), int(e), int(k)) for s, e, k in zip(a, b, cluster)]


def _touch_levels(h, levels, rests, height_tol):
    """``(T,)`` level index each frame touches (-1: none) with two or more levels: runs of
    frames within ``height_tol`` of a level that contain a rest at that level."""
    T = h.shape[0]
    out = np.full(T, -1)
    for k, L in enumerate(levels):
        near = np.abs(h - L) <= height_tol
        if k == 0:
            near |= h < L                       # below the lowest level (noise) still touches it
        run = np.cumsum(np.r_[near[0], near[1:] & ~near[:-1]]) * near   # run id per frame, 0 = not near
        hit = np.zeros(run.max() + 1, bool)
        for s, e, kk in rests:
            if kk == k:
                hit[run[s:e]] = True
        hit[0] = False
        sel = hit[run] & (out < 0)
        out[sel] = k
    return out


def detect_contacts(motion, effectors=None, height_tol: float = 0.05, speed_tol: float = 0.4,
                    ground_y: float | None = None, max_clearance: float = 0.2, min_frames: int = 2,
                    smooth_sigma: float | None = 1.0, rest_speed: float = 0.2,
                    rest_time: float = 0.1) -> ContactResult:
    """Contact labels per end effector from height and speed.

    Parameters
    ----------
    motion: the motion.
    effectors: ``None`` (feet, toe tips and hands via the body-segment mapping), a list of
        joint / end-site names, or a dict name -> joint name or (joint, local offset m).
    height_tol: m above the effector's support level (on one level: the 1st percentile of its
        height); also the gap between rest heights that separates two levels.
    speed_tol: m/s; a touching effector is planted when slower than this.
    ground_y: floor height; default: 2nd percentile of the lowest effector's height per frame.
    max_clearance: effectors whose resting level is more than this above the ground never touch it;
        a rest counts toward a support level only when the effector is at most this far above the
        body's lowest effector.
    rest_speed, rest_time: m/s and s; a rest (evidence of a support level) is at least
        ``rest_time`` (and ``min_frames``) of speeds at most ``rest_speed``.
    min_frames: contact runs and gaps shorter than this many frames (inside the clip) are
        removed (gaps first, then contacts), against single-frame flicker.
    smooth_sigma: Gaussian sigma (frames) on positions before taking speeds.
    """
    for name, v in (("height_tol", height_tol), ("speed_tol", speed_tol), ("max_clearance", max_clearance),
                    ("rest_speed", rest_speed), ("rest_time", rest_time)):
        if not (np.isfinite(v) and v > 0):
            raise ValueError(f"{name} must be positive, got {v!r}")
    eff = _parse_effectors(motion.skeleton, effectors)
    names = tuple(eff)
    joints = np.array([eff[n][0] for n in names], dtype=int)
    offsets = np.array([eff[n][1] for n in names], dtype=float).reshape(-1, 3)
    pos = effector_positions(motion, joints, offsets)
    h_abs = pos[..., 1]
    notes = []
    if ground_y is None:
        ground_y = float(np.percentile(h_abs.min(axis=1), 2))
        notes.append("ground_y: 2nd percentile of the lowest effector height per frame")
    heights = h_abs - ground_y
    levels = np.percentile(heights, 1, axis=0)
    if motion.n_frames >= 2:
        ps = gaussian_smooth(pos, smooth_sigma, axis=0) if smooth_sigma else pos
        speeds = np.linalg.norm(central_difference(ps, motion.times), axis=-1)
    else:
        speeds = np.zeros(heights.shape)
    eligible = levels <= max_clearance
    touching = (heights <= levels + height_tol) & eligible[None]
    contact_levels = np.where(touching, levels[None], np.nan)
    support = {}
    if motion.n_frames >= 2:
        lowest = heights.min(axis=1)
        min_len = max(int(min_frames), int(np.ceil(rest_time * motion.fps - 1e-9)), 2)
        for e, n in enumerate(names):
            lv, rests = _support_levels(heights[:, e], lowest, speeds[:, e], rest_speed, min_len, height_tol,
                                        max_clearance)
            if lv.size >= 2:
                k = _touch_levels(heights[:, e], lv, rests, height_tol)
                touching[:, e] = k >= 0
                contact_levels[:, e] = np.where(k >= 0, lv[np.maximum(k, 0)], np.nan)
                levels[e] = lv[0]
                support[n] = tuple(float(x) for x in lv)
            else:
                support[n] = (float(levels[e]),) if eligible[e] else ()
        if any(len(v) > 1 for v in support.values()):
            notes.append("several support levels: " + ", ".join(
                f"{n} {', '.join(f'{x:.3f}' for x in v)} m" for n, v in support.items() if len(v) > 1))
    labels = touching & (speeds <= speed_tol)
    for arr in (labels, touching):
        for e in range(arr.shape[1]):
            col = _drop_short(arr[:, e], False, min_frames)
            arr[:, e] = _drop_short(col, True, min_frames)
    contact_levels[~touching] = np.nan
    intervals = {n: label_intervals(labels[:, e]) for e, n in enumerate(names)}
    return ContactResult(names, labels, touching, float(ground_y), intervals, pos, heights, speeds, levels,
                         float(height_tol), float(speed_tol), joints, offsets, motion.fps, tuple(notes),
                         support, contact_levels)


def airborne_intervals(contacts: ContactResult, min_frames: int = 1, use: str = "touching") -> list[tuple[int, int]]:
    """Half-open ``(start, stop)`` frame ranges with no ground contact, at least
    ``min_frames`` long (runs touching the clip's ends included).

    ``use="touching"`` (default): no effector near its resting level (height only);
    ``use="planted"``: no effector planted (height and speed) -- longer, since
    take-off and landing frames with a rolling foot count as airborne.
    """
    if use == "touching":
        any_c = contacts.any_touching
    elif use == "planted":
        any_c = contacts.any_contact
    else:
        raise ValueError(f"use must be 'touching' or 'planted', got {use!r}")
    runs = label_intervals(~any_c)
    return [(a, b) for a, b in runs if b - a >= min_frames]
