"""Foot plants: which foot points are planted on which frames, and where they are held.

The planted frames come from the project's contact detector
(:func:`mocomp.dynamics.contacts.detect_contacts`: an effector near its support level *and*
slow), restricted to the feet: per leg the ankle point (``foot_l``/``foot_r``) and the toe tip
(``toe_l``/``toe_r``), on the joints the body-segment mapping gives them. A small CSV
(``joint,start,stop``) overrides the detector for the effectors it names (see
:func:`read_contacts_csv`); ``labels=`` replaces the detection altogether (a blend passes the
labels of its two inputs).

A plant's target (:func:`plant_targets`) is the mean horizontal position of the point over its
planted run, at the height of its support level (the height the point typically rests at on the
detector's level for that effector, the floor it rests on), so a foot that slid is held where it
was on average, on the floor.
"""
from __future__ import annotations

import csv
import functools
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..dynamics.contacts import ContactResult, default_effectors, detect_contacts, label_intervals
from ..errors import MocompError, MotionFormatError

__all__ = ["FootPlants", "LegLayout", "NoContactError", "leg_layout", "foot_plants", "read_contacts_csv",
           "parse_contacts_rows", "plant_targets", "FOOT_EFFECTORS", "HEIGHT_MODES"]

#: how :func:`plant_targets` sets the height of a planted point
HEIGHT_MODES = ("level", "hold", "keep")

#: the detector's foot effectors, per side: (ankle point, toe tip)
FOOT_EFFECTORS = {"l": ("foot_l", "toe_l"), "r": ("foot_r", "toe_r")}


class NoContactError(MocompError, ValueError):
    """A motion (or a part of it an operation needs) has no planted foot: nothing to hold."""


@dataclass(frozen=True)
class LegLayout:
    """One leg: the IK chain and its two foot points.

    Attributes
    ----------
    side: ``"l"`` or ``"r"``.
    chain: ``(hip, knee, ankle)`` joint indices (the ankle carries the ``foot`` point).
    ankle_point: ``(joint, offset (3,) m)`` of the ankle point (detector effector ``foot_<side>``).
    toe_point: ``(joint, offset (3,) m)`` of the toe tip (``toe_<side>``), on the ankle joint or a
        descendant of it; its local rotations are never changed (the foot moves as one body).
    """

    side: str
    chain: tuple[int, int, int]
    ankle_point: tuple[int, np.ndarray]
    toe_point: tuple[int, np.ndarray]


@functools.lru_cache(maxsize=64)
def _effectors_cached(skeleton, ends_key) -> dict:
    return default_effectors(skeleton)


def effectors_of(skeleton) -> dict:
    """:func:`mocomp.dynamics.contacts.default_effectors` of ``skeleton``, cached per skeleton (its
    joints, offsets and end sites): the body-segment mapping behind it takes milliseconds."""
    key = tuple((int(e.parent), tuple(np.round(e.offset, 12).tolist()), e.name) for e in skeleton.end_sites)
    return _effectors_cached(skeleton, key)


def leg_layout(skeleton) -> tuple[LegLayout, LegLayout]:
    """The two legs of ``skeleton`` from the body-segment mapping the contact detector uses
    (:func:`mocomp.dynamics.contacts.default_effectors`): the ankle point's joint is the chain's
    ankle, its parent the knee, its grandparent the hip."""
    eff = effectors_of(skeleton)
    out = []
    for side, (fa, ft) in FOOT_EFFECTORS.items():
        ja, oa = eff[fa]
        jt, ot = eff[ft]
        k = int(skeleton.parents[ja])
        h = int(skeleton.parents[k]) if k >= 0 else -1
        if k < 0 or h < 0:
            raise MotionFormatError(f"the {side} foot joint {skeleton.names[ja]!r} has no knee and hip above it")
        if ja not in skeleton.chain(jt):
            raise MotionFormatError(f"the {side} toe joint {skeleton.names[jt]!r} does not hang from the ankle "
                                    f"{skeleton.names[ja]!r}")
        out.append(LegLayout(side, (h, k, int(ja)), (int(ja), np.asarray(oa, float)), (int(jt), np.asarray(ot, float))))
    return out[0], out[1]


@dataclass(frozen=True, eq=False)
class FootPlants:
    """Planted frames of the four foot points.

    Attributes
    ----------
    effectors: ``("foot_l", "toe_l", "foot_r", "toe_r")``.
    labels: ``(T, 4)`` bool, planted.
    levels: ``(T, 4)`` m, world height of the support level each point rests on (NaN where it
        is not planted).
    source: effector -> ``"detector"``, ``"csv <path>"`` or ``"given"``: where its labels came from.
    legs: the two :class:`LegLayout`.
    contacts: the detector's :class:`~mocomp.dynamics.contacts.ContactResult` (``None`` when the
        labels were given).
    """

    effectors: tuple[str, ...]
    labels: np.ndarray
    levels: np.ndarray
    source: dict
    legs: tuple
    contacts: ContactResult | None = None
    notes: tuple[str, ...] = field(default=())

    @property
    def intervals(self) -> dict:
        """effector -> list of half-open ``(start, stop)`` planted runs."""
        return {e: label_intervals(self.labels[:, k]) for k, e in enumerate(self.effectors)}

    @property
    def n_frames(self) -> int:
        return self.labels.shape[0]

    def to_dict(self) -> dict:
        return {"intervals": {e: [list(r) for r in v] for e, v in self.intervals.items()},
                "source": dict(self.source), "notes": list(self.notes)}


def parse_contacts_rows(rows, skeleton, n_frames: int, path: str = "<contacts>") -> dict[str, list[tuple[int, int]]]:
    """Validate override rows ``(line number, joint, start, stop)``; returns effector -> intervals.

    ``joint`` is a detector effector name (``foot_l``, ``toe_r``) or the name of the joint that
    effector rides on (``LeftFoot``, ``Toes_R``, ...). ``start``/``stop`` are 0-based frames,
    half-open like every interval of the project (``stop`` is the first frame not planted),
    ``0 <= start < stop <= n_frames``."""
    eff = effectors_of(skeleton)
    feet = [e for pair in FOOT_EFFECTORS.values() for e in pair]
    by_joint = {skeleton.names[eff[e][0]]: e for e in feet}
    out: dict[str, list[tuple[int, int]]] = {}
    for line, joint, start, stop in rows:
        name = joint.strip()
        e = name if name in feet else by_joint.get(name)
        if e is None:
            known = ", ".join(feet + [f"{j} ({e})" for j, e in by_joint.items()])
            raise MotionFormatError(f"joint {name!r} is not a foot point of the motion; use one of: {known}",
                                    path, line)
        vals = []
        for what, txt in (("start", start), ("stop", stop)):
            try:
                vals.append(int(str(txt).strip()))
            except ValueError:
                raise MotionFormatError(f"{what} {str(txt).strip()!r} is not a frame number", path, line) from None
        a, b = vals
        if not 0 <= a < b <= n_frames:
            raise MotionFormatError(f"interval start={a}, stop={b} must satisfy 0 <= start < stop <= {n_frames} "
                                    f"(frames of the motion; stop is exclusive)", path, line)
        out.setdefault(e, []).append((a, b))
    return out


def read_contacts_csv(path, skeleton, n_frames: int) -> dict[str, list[tuple[int, int]]]:
    """Read a contact override file: a header line ``joint,start,stop`` and one planted interval a
    row (see :func:`parse_contacts_rows`); ``#`` starts a comment line. Errors name the file and line."""
    path = Path(path)
    text = path.read_text(encoding="utf-8-sig")
    rows = []
    header_seen = False
    for line, row in enumerate(csv.reader(text.splitlines()), start=1):
        if not row or not "".join(row).strip() or row[0].lstrip().startswith("#"):
            continue
        cells = [c.strip() for c in row]
        if not header_seen:
            if [c.lower() for c in cells] != ["joint", "start", "stop"]:
                raise MotionFormatError(f"the first row must be the header 'joint,start,stop', got {','.join(cells)!r}",
                                        path, line)
            header_seen = True
            continue
        if len(cells) != 3:
            raise MotionFormatError(f"expected 3 fields joint,start,stop, got {len(cells)}", path, line)
        rows.append((line, *cells))
    if not header_seen:
        raise MotionFormatError("empty contact file: expected the header 'joint,start,stop'", path)
    return parse_contacts_rows(rows, skeleton, n_frames, str(path))


def foot_plants(motion, overrides: dict | str | Path | None = None, *, labels: np.ndarray | None = None,
                contacts: ContactResult | None = None, require: bool = True, **detector) -> FootPlants:
    """Planted frames of the feet of ``motion``.

    Parameters
    ----------
    overrides: effector -> list of ``(start, stop)`` intervals, or a CSV path
        (:func:`read_contacts_csv`): the named effectors take exactly these intervals.
    labels: ``(T, 4)`` bool for ``("foot_l", "toe_l", "foot_r", "toe_r")``, replacing the detector.
    contacts: a detector result already computed for ``motion`` (else it is run with ``detector``
        keyword arguments).
    require: raise :class:`NoContactError` when no foot point is ever planted.
    """
    legs = leg_layout(motion.skeleton)
    names = tuple(e for pair in FOOT_EFFECTORS.values() for e in pair)
    T = motion.n_frames
    notes = []
    if labels is not None:
        lab = np.asarray(labels, dtype=bool)
        if lab.shape != (T, 4):
            raise ValueError(f"labels must have shape ({T}, 4) for {names}, got {lab.shape}")
        source = {e: "given" for e in names}
        c = contacts
    else:
        c = contacts if contacts is not None else detect_contacts(
            motion, **dict({"effectors": effectors_of(motion.skeleton)}, **detector))
        cols = [c.effectors.index(e) for e in names]
        lab = np.array(c.labels[:, cols])
        source = {e: "detector" for e in names}
    lab = np.array(lab)
    if c is not None:
        cols = [c.effectors.index(e) for e in names]
        lev = np.broadcast_to(c.levels[cols][None], (T, 4))
        if c.contact_levels is not None:                 # several floors: the level each frame touches
            lev = np.where(np.isfinite(c.contact_levels[:, cols]), c.contact_levels[:, cols], lev)
        levels = np.where(lab, c.ground_y + lev, np.nan)
        ground_y = c.ground_y
    else:
        levels = np.full((T, 4), np.nan)
        ground_y = None
    if overrides is not None:
        where = "given"
        if isinstance(overrides, (str, Path)):
            where = f"csv {overrides}"
            overrides = read_contacts_csv(overrides, motion.skeleton, T)
        else:
            overrides = parse_contacts_rows([(None, e, a, b) for e, runs in overrides.items() for a, b in runs],
                                            motion.skeleton, T, "overrides")
        for e, runs in overrides.items():
            k = names.index(e)
            lab[:, k] = False
            for a, b in runs:
                lab[a:b, k] = True
            source[e] = where
    # a planted point without a detector level (given labels, overrides): its lowest height while planted
    if np.any(lab & np.isnan(levels)):
        from ..dynamics.contacts import effector_positions

        joints = [legs[0].ankle_point[0], legs[0].toe_point[0], legs[1].ankle_point[0], legs[1].toe_point[0]]
        offs = [legs[0].ankle_point[1], legs[0].toe_point[1], legs[1].ankle_point[1], legs[1].toe_point[1]]
        y = effector_positions(motion, joints, offs)[..., 1]
        for k in range(4):
            miss = lab[:, k] & np.isnan(levels[:, k])
            if miss.any():
                lvl = float(np.percentile(y[lab[:, k], k], 1)) if ground_y is None else \
                    float(ground_y + np.percentile(y[:, k] - ground_y, 1))
                levels[miss, k] = lvl
        notes.append("support level of planted points without a detector level: 1st percentile of their height")
    levels[~lab] = np.nan
    if require and not lab.any():
        raise NoContactError(
            f"{motion.source.path or 'the motion'}: no foot is planted on any of its {T} frames (contact detector: "
            "no foot point near its support level and slower than its speed threshold); give the plants with "
            "--contacts FILE.csv (joint,start,stop)")
    return FootPlants(names, lab, levels, source, legs, c, tuple(notes))


def plant_targets(points: np.ndarray, plants: FootPlants, height: str = "level") -> np.ndarray:
    """``(T, 4, 3)`` m: where each planted point is held (NaN where it is not planted).

    Per planted run: the mean ``x``, ``z`` of the point over the run (``points (T, 4, 3)``, its
    world positions). ``y``: with ``height="level"`` (default) the point's own height shifted so
    that its lowest height in the run lies on the support level the point rests on (with
    :data:`ROBUST_LEVEL`, the median of its runs' lowest heights on that detector level,
    :func:`_resting_levels`, for a point planted by the detector; a point whose plants were given or
    read from a CSV file goes on its level as it is, the 1st percentile of its height over its planted
    frames; the heel still rolls up at the end of a stance, on the floor);
    ``"hold"`` the detector's support level on every frame (held still in 3-D); ``"keep"`` its own
    height."""
    if height not in HEIGHT_MODES:
        raise ValueError(f"height must be one of {', '.join(HEIGHT_MODES)}, got {height!r}")
    T = plants.n_frames
    out = np.full((T, 4, 3), np.nan)
    for k in range(4):
        lab = plants.labels[:, k]
        sel = np.flatnonzero(lab)
        if sel.size == 0:
            continue
        first = np.flatnonzero(np.r_[True, np.diff(sel) > 1])          # run starts, as positions in ``sel``
        cnt = np.diff(np.r_[first, sel.size])
        p = points[sel, k]
        mean = np.add.reduceat(p, first, axis=0) / cnt[:, None]        # runs are contiguous: one sum per run
        rid = np.repeat(np.arange(first.size), cnt)
        out[sel, k] = mean[rid]
        y = p[:, 1]
        if height == "hold":
            out[sel, k, 1] = plants.levels[sel, k]
        elif height == "keep":
            out[sel, k, 1] = y
        else:
            low = np.minimum.reduceat(y, first)
            rest = ROBUST_LEVEL and plants.source.get(plants.effectors[k]) == "detector"
            out[sel, k, 1] = y - low[rid] + (_resting_levels(low, plants.levels[sel[first], k])[rid]
                                             if rest else plants.levels[sel, k])
    if height == "level" and ROBUST_LEVEL:
        _toes_with_their_heels(out, points, plants)
    return out


def _toes_with_their_heels(out: np.ndarray, points: np.ndarray, plants: FootPlants) -> None:
    """In place: a toe-tip plant (points 1 and 3) that overlaps plants of its foot's ankle point
    (0 and 2) is moved up or down by the same amount as the ankle point's plant it shares most frames
    with, over its whole run, so the foot keeps its pitch: two points put on resting levels of their
    own (a raw CMU toe sunk 5 cm through the floor while the heel rests 1 cm above it) would ask for a
    foot pitched otherwise than the input's, which the rigid foot can only meet by sliding both
    points along itself or by a steep change of pitch. Only points planted by the detector (resting
    levels), and only where the two shifts differ by more than :data:`TOE_HEEL_GAP`."""
    for ka, kt in ((0, 1), (2, 3)):
        if any(plants.source.get(plants.effectors[k]) != "detector" for k in (ka, kt)):
            continue
        la, lt = plants.labels[:, ka], plants.labels[:, kt]
        if not (la & lt).any():
            continue
        shift_a = out[:, ka, 1] - points[:, ka, 1]                     # constant over each ankle run
        ra = np.cumsum(np.r_[la[0], la[1:] & ~la[:-1]]) * la            # ankle run id per frame (0: none)
        rt = np.cumsum(np.r_[lt[0], lt[1:] & ~lt[:-1]]) * lt            # toe run id per frame
        sh = np.flatnonzero(la & lt)
        # per toe run, the ankle run it shares most frames with (the first of equals) and its shift
        pairs, first, cnt = np.unique(rt[sh] * (int(ra.max()) + 1) + ra[sh], return_index=True, return_counts=True)
        toe_run = pairs // (int(ra.max()) + 1)
        order = np.lexsort((first, -cnt, toe_run))
        keep = order[np.r_[True, toe_run[order][1:] != toe_run[order][:-1]]]
        shift = np.full(int(rt.max()) + 1, np.nan)
        shift[toe_run[keep]] = shift_a[sh[first[keep]]]
        f = np.flatnonzero(lt)
        s_t = shift[rt[f]]
        starts = np.r_[0, np.flatnonzero(np.diff(f) > 1) + 1]           # the toe's own shift, per run
        own = np.repeat((out[f, kt, 1] - points[f, kt, 1])[starts], np.diff(np.r_[starts, f.size]))
        move = np.isfinite(s_t) & (np.abs(own - s_t) > TOE_HEEL_GAP)
        out[f[move], kt, 1] = points[f[move], kt, 1] + s_t[move]


#: m: :func:`_toes_with_their_heels` moves a toe plant with its heel's only where their own shifts
#: differ by more than this (a toe sunk centimetres through the floor); smaller differences are left to
#: the foot's pitch (:func:`mocomp.ops.footplant.bounded_foot_pitch`)
TOE_HEEL_GAP = 0.02


#: ``plant_targets(height="level")``: each plant's lowest height goes on the median resting height of
#: that point over its plants on the same support level (see :func:`_resting_levels`); ``False``: on the
#: detector's level (the 1st percentile of the point's height over the clip)
ROBUST_LEVEL = True


def _resting_levels(low: np.ndarray, level: np.ndarray) -> np.ndarray:
    """Per plant run of one point: the height its lowest frame is put on. ``low``: the runs' lowest
    heights; ``level``: the detector's support level of each run. Runs on one support level (levels
    within 1 mm) share the median of their lows: the height the point typically rests at on that floor.
    The detector's level is the 1st percentile of the point's height over the clip, which a few frames
    of the point sunk through the floor (raw CMU toes) pull centimetres below where it rests: putting
    every plant there lowers most of them by centimetres, which the audit then finds as contacts the
    input does not have (a lowered foot is still near the floor while the correction fades out)."""
    out = np.array(level, dtype=float)
    key = np.round(level, 3)
    for v in np.unique(key[np.isfinite(key)]):
        g = key == v
        out[g] = np.median(low[g])
    return out
