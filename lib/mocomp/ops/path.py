"""Path editing: a motion moved onto a new ground path (issue 15, item 4; Gleicher 2001,
"Motion path editing", as the touch-up paper's sec. 4.3 input).

The motion's own path is its root's ground track smoothed over ``path_sigma`` seconds (a walk's
sway from step to step removed); its heading is that path's tangent (held through frames where
the root hardly moves, e.g. standing between hops). Each frame is written in the path's moving
frame: arc length ``s(t)`` travelled so far, and the root's offset from the path point and its
orientation relative to the tangent (the fine root motion). The new path is a
:class:`PathCurve` (polyline or an interpolating cubic spline through points in the ground
plane, x and z in metres) walked at the same arc length: the root goes to
``C(s) + R_y(psi_C(s) - psi(t)) (root - path(t))`` and turns by the same angle, so the body
faces along the new tangent and keeps its sway, bounce and step lengths. The joints are
untouched; the feet, which would slide where the path bends, are planted again with
:func:`~mocomp.ops.footplant.enforce_footplants` on the input's plants.

Beyond the curve's last point the motion continues straight along the last tangent (the
evidence says how far). A curve whose direction reverses on the spot (a cusp: a polyline corner
sharper than :data:`MAX_CORNER_DEG`, or a spline whose tangent turns by more than 90 deg within
:data:`CUSP_ARC` of arc length) has no tangent to follow there: :class:`CurveError`.
"""
from __future__ import annotations

import csv
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.ndimage import gaussian_filter1d

from ..core.motion import Motion
from ..errors import MocompError
from .align import yaw_quaternion

__all__ = ["CurveError", "PathCurve", "PathEditResult", "path_edit", "motion_path", "step_lengths",
           "path_distance", "MAX_CORNER_DEG", "CUSP_ARC"]

#: deg: a polyline corner turning more than this is a cusp
MAX_CORNER_DEG = 150.0
#: m: a spline whose tangent turns by more than 90 deg within this arc length has a cusp
CUSP_ARC = 0.05
_STEP = 0.005          # m, arc-length spacing of the curve tables


class CurveError(MocompError, ValueError):
    """A ground path that cannot be followed: too few or repeated points, non-finite values, a cusp."""


def _angle(d: np.ndarray) -> np.ndarray:
    """Heading angle (rad, about +y) of ground directions ``(..., 2)`` given as ``(x, z)``: +z is 0."""
    return np.arctan2(d[..., 0], d[..., 1])


@dataclass(frozen=True, eq=False)
class PathCurve:
    """A ground path through ``points (n, 2)`` (x, z in metres): ``kind="polyline"`` (straight
    segments; the heading turns at a corner over ``corner`` metres of arc length, centred on it) or
    ``"spline"`` (cubic interpolating spline by chord length; quadratic for 3 points, a line for 2)."""

    points: np.ndarray
    kind: str = "spline"
    corner: float = 0.5

    def __post_init__(self):
        p = np.array(self.points, dtype=float)
        if p.ndim != 2 or p.shape[1] != 2:
            raise CurveError(f"a curve needs points as (x, z) pairs, got an array of shape {p.shape}")
        if p.shape[0] < 2:
            raise CurveError(f"a curve needs at least 2 points, got {p.shape[0]}")
        if not np.all(np.isfinite(p)):
            k = int(np.argmax(~np.isfinite(p).all(axis=1)))
            raise CurveError(f"curve point {k + 1} is not finite: {p[k].tolist()}")
        seg = np.linalg.norm(np.diff(p, axis=0), axis=1)
        if np.any(seg < 1e-9):
            k = int(np.argmax(seg < 1e-9))
            raise CurveError(f"curve points {k + 1} and {k + 2} coincide at ({p[k, 0]:g}, {p[k, 1]:g})")
        if self.kind not in ("polyline", "spline"):
            raise CurveError(f"curve kind must be 'polyline' or 'spline', got {self.kind!r}")
        if not (np.isfinite(self.corner) and self.corner >= 0):
            raise CurveError(f"corner must be 0 or more metres, got {self.corner!r}")
        p.setflags(write=False)
        object.__setattr__(self, "points", p)
        s, xy, psi = self._table()
        for a in (s, xy, psi):
            a.setflags(write=False)
        object.__setattr__(self, "_s", s)
        object.__setattr__(self, "_xy", xy)
        object.__setattr__(self, "_psi", psi)

    # ---------------------------------------------------------------- construction
    @classmethod
    def parse(cls, text: str, kind: str = "spline") -> "PathCurve":
        """From ``"x,z;x,z;..."`` (metres); errors name the point."""
        pts = []
        items = [t for t in str(text).split(";")]
        for k, item in enumerate(items, 1):
            if not item.strip():
                if k == len(items):          # a trailing ';'
                    continue
                raise CurveError(f"curve point {k} is empty (expected 'x,z')")
            parts = item.split(",")
            if len(parts) != 2:
                raise CurveError(f"curve point {k} {item.strip()!r} is not 'x,z'")
            try:
                pts.append([float(parts[0]), float(parts[1])])
            except ValueError:
                raise CurveError(f"curve point {k} {item.strip()!r} is not two numbers 'x,z'") from None
        return cls(np.array(pts).reshape(-1, 2), kind)

    @classmethod
    def read_csv(cls, path, kind: str = "spline") -> "PathCurve":
        """From a CSV file of ``x,z`` rows (metres; an optional header ``x,z``; ``#`` comments).
        Errors name the file and line."""
        from ..errors import MotionFormatError

        path = Path(path)
        pts = []
        for line, row in enumerate(csv.reader(path.read_text(encoding="utf-8-sig").splitlines()), 1):
            cells = [c.strip() for c in row]
            if not cells or not "".join(cells) or cells[0].startswith("#"):
                continue
            if not pts and [c.lower() for c in cells] == ["x", "z"]:
                continue
            if len(cells) != 2:
                raise MotionFormatError(f"expected 2 fields x,z, got {len(cells)}", path, line)
            try:
                pts.append([float(cells[0]), float(cells[1])])
            except ValueError:
                raise MotionFormatError(f"{','.join(cells)!r} is not two numbers x,z", path, line) from None
        try:
            return cls(np.array(pts).reshape(-1, 2), kind)
        except CurveError as e:
            raise CurveError(f"{path}: {e}") from None

    @classmethod
    def arc(cls, length: float, turn: float, start=(0.0, 0.0), heading: float = 0.0, n: int = 33) -> "PathCurve":
        """A circular arc of ``length`` m turning by ``turn`` rad (positive: to the left, i.e.
        counter-clockwise seen from above), starting at ``start`` with heading ``heading`` rad
        (0: along +z); a straight line for ``turn = 0``."""
        if not (np.isfinite(length) and length > 0):
            raise CurveError(f"arc length must be positive, got {length!r}")
        s = np.linspace(0.0, length, n)
        if abs(turn) < 1e-12:
            th = np.full(n, heading)
            x = np.sin(heading) * s
            z = np.cos(heading) * s
        else:
            k = turn / length
            th = heading + k * s
            x = (np.cos(heading) - np.cos(th)) / k
            z = (np.sin(th) - np.sin(heading)) / k
        return cls(np.column_stack([x, z]) + np.asarray(start, dtype=float), "spline")

    def rotated(self, degrees: float) -> "PathCurve":
        """The curve turned about its first point by ``degrees`` (positive: counter-clockwise seen
        from above, the same sense as a heading)."""
        a = np.radians(degrees)
        R = np.array([[np.cos(a), np.sin(a)], [-np.sin(a), np.cos(a)]])      # (x, z) by R_y(a)
        p0 = self.points[0]
        return PathCurve((self.points - p0) @ R.T + p0, self.kind, self.corner)

    # ---------------------------------------------------------------- geometry
    def _table(self):
        p = self.points
        if self.kind == "polyline" or p.shape[0] == 2:
            seg = np.linalg.norm(np.diff(p, axis=0), axis=1)
            d = np.diff(p, axis=0) / seg[:, None]
            turn = np.degrees(np.abs(np.angle(np.exp(1j * (np.diff(_angle(d)))))))
            if turn.size and turn.max() > MAX_CORNER_DEG:
                k = int(np.argmax(turn)) + 1
                raise CurveError(f"the curve has a cusp at point {k + 1} ({p[k, 0]:g}, {p[k, 1]:g}): it turns by "
                                 f"{turn[k - 1]:.0f} deg there (more than {MAX_CORNER_DEG:g}), so the heading would "
                                 "reverse on the spot; round the corner or split the path there")
            cum = np.r_[0.0, np.cumsum(seg)]
            s = np.arange(0.0, cum[-1], _STEP)
            s = np.r_[s, cum[-1]]
            k = np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(seg) - 1)
            xy = p[k] + (s - cum[k])[:, None] * d[k]
            tan = d[k]
            if self.corner > 0 and len(seg) > 1:
                tan = gaussian_filter1d(tan, max(self.corner / 2.0 / _STEP, 1e-6), axis=0, mode="nearest")
            psi = np.unwrap(_angle(tan))
            return s, xy, psi
        from scipy.interpolate import make_interp_spline

        u = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))]
        k = min(3, p.shape[0] - 1)
        spl = make_interp_spline(u, p, k=k)
        n = max(64, int(np.ceil(u[-1] / _STEP * 2)))
        uu = np.linspace(0.0, u[-1], n)
        xy = spl(uu)
        dxy = spl.derivative()(uu)
        sp = np.linalg.norm(dxy, axis=1)
        s = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(xy, axis=0), axis=1))]
        ang = np.unwrap(_angle(dxy))
        # a cusp: the tangent turns by more than 90 deg within CUSP_ARC of arc length (or the speed vanishes)
        j = np.searchsorted(s, s + CUSP_ARC)
        j = np.minimum(j, n - 1)
        sharp = np.abs(ang[j] - ang) > np.pi / 2
        tiny = sp < 1e-6 * max(u[-1], 1e-9)
        if np.any(sharp) or np.any(tiny):
            i = int(np.argmax(sharp | tiny))
            raise CurveError(f"the spline through the points has a cusp near ({xy[i, 0]:.3g}, {xy[i, 1]:.3g}), "
                             f"{s[i]:.3g} m along it: its direction reverses within {CUSP_ARC * 100:.0f} cm, so the "
                             "heading cannot follow the tangent; move or remove the points that fold back")
        return s, xy, ang

    @property
    def length(self) -> float:
        return float(self._s[-1])

    def evaluate(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(points (n, 2), headings (n,))`` at arc lengths ``s`` (m): the heading is the tangent's
        angle about +y (0 along +z). Beyond either end the curve continues straight along its end
        tangent."""
        s = np.asarray(s, dtype=float)
        S, XY, PSI = self._s, self._xy, self._psi
        inside = np.clip(s, 0.0, S[-1])
        xy = np.column_stack([np.interp(inside, S, XY[:, 0]), np.interp(inside, S, XY[:, 1])])
        psi = np.interp(inside, S, PSI)
        over = s - inside
        if np.any(over != 0):
            d = np.column_stack([np.sin(psi), np.cos(psi)])
            xy = xy + over[:, None] * d
        return xy, psi

    def to_dict(self) -> dict:
        return {"kind": self.kind, "points": self.points.tolist(), "length_m": self.length}


def motion_path(motion: Motion, path_sigma: float = 0.5, min_speed: float = 0.3):
    """The motion's own ground path: ``(path (T, 2) x,z m, arc length (T,) m, heading (T,) rad)``:
    the root's ground track smoothed by a Gaussian of ``path_sigma`` s, its arc length from frame 0
    and its tangent's heading. Where the path moves slower than ``min_speed`` m/s (0.3: a slow, tight
    turn of the smoothed path near a stop is no heading to follow) the tangent is
    undefined: at the clip's ends it is held from the nearest moving frame; through a pause it turns
    from its direction before to its direction after with the body's heading (a walk that turns
    around on the spot keeps facing along its path)."""
    xz = motion.root_positions[:, [0, 2]]
    sig = path_sigma * motion.fps
    path = gaussian_filter1d(xz, sig, axis=0, mode="nearest") if sig > 0 and motion.n_frames > 1 else np.array(xz)
    s = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(path, axis=0), axis=1))]
    if motion.n_frames < 2:
        raise CurveError("path editing needs a motion of at least 2 frames")
    v = np.gradient(path, axis=0) * motion.fps
    speed = np.linalg.norm(v, axis=1)
    moving = speed > min_speed
    if not moving.any():
        raise CurveError(f"{motion.source.path or 'the motion'} does not travel (its smoothed root path moves at most "
                         f"{speed.max():.3f} m/s, {s[-1]:.3f} m in all): there is no path to edit")
    T = motion.n_frames
    idx = np.arange(T)
    prev = np.maximum.accumulate(np.where(moving, idx, -1))
    nxt = np.minimum.accumulate(np.where(moving, idx, T)[::-1])[::-1]
    near = np.where(prev < 0, nxt, np.where(nxt >= T, prev, np.where(idx - prev <= nxt - idx, prev, nxt)))
    psi = _angle(v[near])
    # through a pause between two moving stretches (standing, turning on the spot) the tangent turns
    # with the body: from its direction before to its direction after, in the body's sense of turning
    from .align import headings

    head = None
    for a, b in _runs(~moving):
        if a == 0 or b == T:
            continue
        if head is None:
            head = headings(motion)
        p0, p1 = _angle(v[a - 1]), _angle(v[b])
        dh = float(head[b] - head[a - 1])
        d = p1 - p0
        d = d + 2 * np.pi * np.round((dh - d) / (2 * np.pi))            # the turn nearest the body's
        w = (head[a:b] - head[a - 1]) / dh if abs(dh) > 1e-3 else (np.arange(a, b) - a + 1) / (b - a + 1)
        psi[a:b] = p0 + d * np.clip(w, 0.0, 1.0)
    psi = np.unwrap(psi)
    return path, s, psi


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    from ..dynamics.contacts import label_intervals

    return label_intervals(mask)


@dataclass(frozen=True, eq=False)
class PathEditResult:
    """A path-edited motion and its evidence.

    Attributes
    ----------
    motion: the result (footplants enforced unless ``plant=False``).
    unplanted: the motion moved onto the curve before the feet were planted again.
    curve: the :class:`PathCurve`.
    path_length: m, arc length of the input's smoothed path; curve_length: m.
    extended: m travelled beyond the curve's end (straight along its last tangent).
    turn: rad, the heading change the edit added from the first frame to the last.
    heading_rate_max: rad/s, the largest rate of the added heading change.
    footplants: the :class:`~mocomp.ops.footplant.FootplantResult` (or ``None``).
    input: the input motion; plants: its :class:`~mocomp.ops.plants.FootPlants` (enforced on the result).
    step_before, step_after: ``(n,)`` m, step lengths (:func:`step_lengths`) of input and result
        (properties, computed on first use).
    """

    motion: Motion
    unplanted: Motion
    curve: PathCurve
    path_length: float
    curve_length: float
    extended: float
    turn: float
    heading_rate_max: float
    footplants: object | None
    input: Motion
    plants: object
    seconds: float = 0.0
    notes: tuple[str, ...] = field(default=())
    _cache: dict = field(default_factory=dict, repr=False)

    @property
    def step_before(self) -> np.ndarray:
        """``(n,)`` m, step lengths of the input (:func:`step_lengths`, computed on first use)."""
        if "before" not in self._cache:
            self._cache["before"] = step_lengths(self.input, self.plants)
        return self._cache["before"]

    @property
    def step_after(self) -> np.ndarray:
        """``(n,)`` m, step lengths of the result on the same plants."""
        if "after" not in self._cache:
            self._cache["after"] = step_lengths(self.motion, self.plants)
        return self._cache["after"]

    def to_dict(self) -> dict:
        d = {"curve": self.curve.to_dict(), "path_length_m": self.path_length, "curve_length_m": self.curve_length,
             "extended_m": self.extended, "turn_deg": float(np.degrees(self.turn)),
             "heading_rate_max_deg_s": float(np.degrees(self.heading_rate_max)),
             "step_length_before_m": _stats(self.step_before), "step_length_after_m": _stats(self.step_after),
             "seconds": self.seconds, "notes": list(self.notes)}
        if self.footplants is not None:
            d["footplants"] = self.footplants.to_dict()
        return d


def _stats(x) -> dict:
    x = np.asarray(x, dtype=float)
    return {"n": int(x.size), "mean": float(x.mean()) if x.size else None, "std": float(x.std()) if x.size else None}


def step_lengths(motion: Motion, plants=None) -> np.ndarray:
    """``(n,)`` m: ground distance between successive foot strikes (the plant targets of the ankle
    points, ordered by plant start, alternating feet only: a foot planted twice in a row is one
    step of the other foot's length 0 and is skipped)."""
    from .footplant import foot_points
    from .plants import foot_plants, plant_targets

    pl = foot_plants(motion, require=False) if plants is None else plants
    P, G = motion.fk()
    tg = plant_targets(foot_points(P, G, pl), pl, "keep")
    ev = []
    for k, side in ((0, "l"), (2, "r")):
        for a, b in pl.intervals[pl.effectors[k]]:
            ev.append((a, side, tg[a, k, [0, 2]]))
    ev.sort(key=lambda e: e[0])
    out = [float(np.linalg.norm(q[2] - p[2])) for p, q in zip(ev, ev[1:]) if p[1] != q[1]]
    return np.array(out)


def path_distance(motion: Motion, reference_xz: np.ndarray) -> np.ndarray:
    """``(T,)`` m: distance of each root ground position from the polyline ``reference_xz (n, 2)``
    (e.g. a captured motion's root track), the nearest point on any segment."""
    p = motion.root_positions[:, [0, 2]]
    r = np.asarray(reference_xz, dtype=float)
    a, b = r[:-1], r[1:]
    ab = b - a
    L2 = np.maximum(np.sum(ab * ab, axis=1), 1e-18)
    t = np.clip(np.einsum("tsk,sk->ts", p[:, None] - a[None], ab) / L2[None], 0.0, 1.0)
    q = a[None] + t[..., None] * ab[None]
    return np.linalg.norm(p[:, None] - q, axis=2).min(axis=1)


def _moved_fk(motion: Motion, root_positions: np.ndarray, dpsi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The FK of the moved motion: the input's body turned by ``dpsi (T,)`` rad about the vertical
    through its root and put on the new ``root_positions (T, 3)``, frame by frame (``G' = q_y G``, ``P' = root' +
    R_y (P - root)``), the input's FK being computed anyway for its plants. Equal to a full FK of
    ``moved`` to rounding (~1e-15 m) at a third of its cost."""
    P, G = motion.fk()
    c, s = np.cos(dpsi)[:, None], np.sin(dpsi)[:, None]
    d = P - motion.root_positions[:, None]
    rp = root_positions[:, None]
    Pm = np.empty_like(P)
    Pm[..., 0] = rp[..., 0] + c * d[..., 0] + s * d[..., 2]
    Pm[..., 1] = rp[..., 1] + d[..., 1]
    Pm[..., 2] = rp[..., 2] - s * d[..., 0] + c * d[..., 2]
    ch, sh = np.cos(0.5 * dpsi)[:, None], np.sin(0.5 * dpsi)[:, None]     # q_y = (0, sh, 0, ch)
    Gm = np.empty_like(G)
    Gm[..., 0] = ch * G[..., 0] + sh * G[..., 2]
    Gm[..., 1] = ch * G[..., 1] + sh * G[..., 3]
    Gm[..., 2] = ch * G[..., 2] - sh * G[..., 0]
    Gm[..., 3] = ch * G[..., 3] - sh * G[..., 1]
    return Pm, Gm


def path_edit(motion: Motion, curve: PathCurve, *, path_sigma: float = 0.5, plant: bool = True,
              contacts=None, audit: bool = False) -> PathEditResult:
    """Move ``motion`` onto ``curve`` (see the module docstring).

    Parameters
    ----------
    path_sigma: s, smoothing of the motion's own path (its fine root motion is what is left).
    plant: enforce the input's foot plants on the result.
    contacts: overrides of the plants (CSV path or effector -> intervals, see
        :func:`~mocomp.ops.plants.foot_plants`).
    audit: with ``plant``, audit the input and the result too.
    """
    t0 = time.perf_counter()
    if not isinstance(curve, PathCurve):
        raise TypeError(f"curve must be a PathCurve, got {type(curve).__name__}")
    path, s, psi = motion_path(motion, path_sigma)
    xy, psi_new = curve.evaluate(s)
    dpsi = psi_new - psi
    q = yaw_quaternion(dpsi)
    off = motion.root_positions - np.column_stack([path[:, 0], np.zeros(len(s)), path[:, 1]])
    from ..core.rotations import quat_apply, quat_multiply

    off = quat_apply(q, off)
    rp = np.column_stack([xy[:, 0] + off[:, 0], motion.root_positions[:, 1], xy[:, 1] + off[:, 2]])
    rot = np.array(motion.rotations)
    rot[:, 0] = quat_multiply(q, rot[:, 0])
    # unit quaternions, finite: made from the checked input; its FK derived exactly from the input's
    moved = motion.replace_trusted(rp, rot, fk=_moved_fk(motion, rp, dpsi))
    notes = []
    extended = float(max(0.0, s[-1] - curve.length))
    if extended > 1e-3:
        notes.append(f"the motion travels {s[-1]:.2f} m, the curve is {curve.length:.2f} m long: the last "
                     f"{extended:.2f} m continue straight along the curve's end tangent")
    fp = None
    out = moved
    from .plants import foot_plants

    plants_in = foot_plants(motion, contacts, require=plant)
    if plant:
        from .footplant import enforce_footplants

        if plants_in.labels.any():
            fp = enforce_footplants(moved, plants_in, audit=audit)
            out = fp.motion
    rate = np.abs(np.gradient(dpsi)) * motion.fps if motion.n_frames > 1 else np.zeros(1)
    return PathEditResult(out, moved, curve, float(s[-1]), curve.length, extended, float(dpsi[-1] - dpsi[0]),
                          float(rate.max()), fp, motion, plants_in, time.perf_counter() - t0, tuple(notes))
