"""The final blend onto the found clip (dissertation sec. 4.2, last paragraph), and the output's repairs.

"We linearly interpolate the root node position, distributing the global position error across
the simulated sequence. Joint angles are interpolated by slerping using a simple linear weighting
in time across the transition." With the simulated segment ``s_0 .. s_n`` (``s_0`` the motion
capture frame the simulation started from, ``s_n`` the re-entry frame) and the found clip ``c``
aligned on the same frames, the weight is ``w_i = i / n`` and

* root position: ``s_i + w_i (c_i - s_i)``, the linear interpolation of the two root positions
  frame by frame (the position error spread over the segment with the same weights as the joints),
* every joint's local rotation (the root's orientation included): ``slerp(s_i, c_i, w_i)``,

so frame ``n`` is exactly the found clip's and frame 0 exactly the simulation's start. At the
re-entry the blend moves with the clip's velocity plus the error rate ``(c_n - s_n) / n``: the
simulation's own velocity, which can differ much from the clip's right after a hit, does not carry
over the seam (it would with the re-entry error ``c_n - s_n`` alone added as ``s_i + w_i (c_n - s_n)``,
the other reading of the paper's sentence; :func:`final_blend` ``root="end_error"``). The
*correction* a blend applies -- the root error ``|c_n - s_n|`` and the joint angles between ``s_i``
and ``c_i`` weighted by ``w_i`` -- measures how far the simulation ended from the clip; the
active simulation should make it smaller than blending straight from the naive one.

:func:`floor_lift` repairs clips that go below the floor (the ASE falls' lying phases sink joint
centres 0.10-0.19 m, a retargeting artefact the data MANIFEST names) by lifting the root, smoothly
in time, by what the lowest point lacks; :func:`plant_feet` holds the planted feet with
:func:`mocomp.ops.enforce_footplants` (Foundation III).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import gaussian_filter1d, maximum_filter1d

from ..core.motion import Motion, slerp
from ..core.rotations import quat_angle, quat_inverse, quat_multiply
from ..dynamics.contacts import label_intervals

__all__ = ["BlendOutcome", "final_blend", "correction", "floor_lift", "unsupported_frames", "linear_over", "ballistic_com", "plant_feet", "frame_steps",
           "wrist_props", "props_above_floor", "keep_before",
           "limit_plant_steps"]


@dataclass(frozen=True)
class BlendOutcome:
    """The blended segment and the correction it applied.

    motion: the blended segment (same frames as the simulated one).
    root_error_m: ``|c_n - s_n|``, the root position error at the re-entry; root_error_vertical_m (signed,
    clip minus simulation) and root_error_horizontal_m: its parts. With the pipeline's realignment the
    found clip is aligned on the simulation's root ground point at the re-entry, so the horizontal part is
    zero and the error is the pelvis height difference -- which the joint servos change only through
    the pose (the root is unactuated).
    joint_error_deg: mean over joints of the angle between simulation and clip at re-entry.
    mean_correction_deg: mean over frames and joints of ``w_i * angle(s_i, c_i)`` (what the slerp moved).
    max_correction_deg: its largest value over frames and joints.
    """

    motion: Motion
    root_error_m: float
    joint_error_deg: float
    mean_correction_deg: float
    max_correction_deg: float
    root_error_vertical_m: float = float("nan")
    root_error_horizontal_m: float = float("nan")

    def to_dict(self) -> dict:
        return {"root_error_m": self.root_error_m, "root_error_vertical_m": self.root_error_vertical_m,
                "root_error_horizontal_m": self.root_error_horizontal_m,
                "joint_error_at_reentry_deg": self.joint_error_deg,
                "mean_correction_deg": self.mean_correction_deg, "max_correction_deg": self.max_correction_deg}


def correction(sim: Motion, clip: Motion) -> dict:
    """The correction :func:`final_blend` would apply to ``sim`` to land on ``clip`` (same frames)."""
    n = sim.n_frames - 1
    w = np.arange(sim.n_frames) / max(n, 1)
    ang = np.degrees(quat_angle(quat_multiply(quat_inverse(sim.rotations), clip.rotations)))
    applied = w[:, None] * ang
    e = clip.root_positions[-1] - sim.root_positions[-1]
    return {"root_error_m": float(np.linalg.norm(e)), "root_error_vertical_m": float(e[1]),
            "root_error_horizontal_m": float(np.hypot(e[0], e[2])),
            "joint_error_deg": float(ang[-1].mean()), "mean_correction_deg": float(applied.mean()),
            "max_correction_deg": float(applied.max())}


def final_blend(sim: Motion, clip: Motion, root: str = "interpolate", weights: str = "linear") -> BlendOutcome:
    """Blend the simulated segment ``sim`` onto ``clip`` (the found clip aligned on the same frames),
    see the module docstring. Ends exactly on ``clip``'s last frame. ``root``: ``"interpolate"``
    (``s_i + w_i (c_i - s_i)``, default) or ``"end_error"`` (``s_i + w_i (c_n - s_n)``).
    ``weights``: ``"linear"`` (the paper's ``w_i = i / n``) or ``"smoothstep"`` (``3x^2 - 2x^3`` of
    ``i / n``: the error rate is zero at both seams, so the blend leaves the simulation and enters
    the clip with their own velocities -- at the cost of 1.5x the linear rate mid-segment) or
    ``"smootherstep"`` (``6x^5 - 15x^4 + 10x^3``: also zero acceleration there; the last frame's weight
    step is ``~10/n^3`` instead of ``3/n^2``, 1.9x the linear rate mid-segment)."""
    if root not in ("interpolate", "end_error"):
        raise ValueError(f"root must be 'interpolate' or 'end_error', got {root!r}")
    if weights not in ("linear", "smoothstep", "smootherstep"):
        raise ValueError(f"weights must be 'linear', 'smoothstep' or 'smootherstep', got {weights!r}")
    if sim.n_frames != clip.n_frames or sim.skeleton.names != clip.skeleton.names:
        raise ValueError(f"final_blend: the segment ({sim.n_frames} frames) and the clip ({clip.n_frames} frames) "
                         "must cover the same frames on the same skeleton")
    n = sim.n_frames - 1
    w = np.arange(sim.n_frames) / max(n, 1)
    if weights != "linear":
        from ..ops import ease

        w = ease(w, weights)
    target = clip.root_positions if root == "interpolate" else clip.root_positions[-1]
    root_out = sim.root_positions + w[:, None] * (target - (sim.root_positions if root == "interpolate"
                                                           else sim.root_positions[-1]))
    rot = slerp(sim.rotations, clip.rotations, np.broadcast_to(w[:, None], sim.rotations.shape[:2]))
    rot[-1] = clip.rotations[-1]
    root_out[-1] = clip.root_positions[-1]
    c = correction(sim, clip)
    out = sim.replace(root_positions=root_out, rotations=rot)
    return BlendOutcome(out, c["root_error_m"], c["joint_error_deg"], c["mean_correction_deg"],
                        c["max_correction_deg"], c["root_error_vertical_m"], c["root_error_horizontal_m"])


def frame_steps(motion: Motion) -> tuple[np.ndarray, np.ndarray]:
    """``(root (T-1,) m, joint (T-1,) rad)``: per frame step the root displacement and the largest
    joint rotation change (local rotations) -- the continuity measures."""
    dr = np.linalg.norm(np.diff(motion.root_positions, axis=0), axis=1)
    q = motion.rotations
    dq = quat_angle(quat_multiply(quat_inverse(q[:-1]), q[1:]))
    return dr, dq.max(axis=1)


def wrist_props(skeleton) -> tuple[int, ...]:
    """Prop joints (:data:`mocomp.impact.attacker.PROPS`: ASE's sword) that a turn of their parent
    alone can move: the parent's every child joint is a prop (the hand holding the sword), so turning
    the wrist moves the prop and nothing of the body. The ASE shield hangs from the forearm beside
    the hand and is not one."""
    from .attacker import PROPS

    names = [n.lower() for n in skeleton.names]
    parents = np.asarray(skeleton.parents)
    out = []
    for j, n in enumerate(names):
        p = int(parents[j])
        if j == 0 or p < 0 or not any(w in n for w in PROPS) or any(w in names[p] for w in PROPS):
            continue
        kids = np.nonzero(parents == p)[0]
        if all(any(w in names[k] for w in PROPS) for k in kids) and not np.any(parents == j):
            out.append(j)
    return tuple(out)


def floor_lift(motion: Motion, floor_y: float, *, smooth_frames: float = 2.0,
               tolerance: float = 0.005, start: int = 0, ramp_frames: int = 0,
               exclude: tuple[int, ...] = (), ballistic: bool = False) -> tuple[Motion, np.ndarray]:
    """``(motion, lift (T,))``: the root raised per frame so that no joint or end site is more than
    ``tolerance`` (m) below ``floor_y`` (m), the lift smoothed in time (a running maximum over ``3 * smooth_frames`` frames each
    side, then a Gaussian of ``smooth_frames``: never less than what a frame needs, no jumps).
    Frames that need nothing keep a zero lift unless within the smoothing of one that does.
    ``start``: frames before it are never lifted (the input clip before the impact); the lift then
    eases in over ``ramp_frames`` frames from ``start`` (never below what a frame needs).
    ``exclude``: joints (and their end sites) that do not count (:func:`wrist_props`, which
    :func:`props_above_floor` turns out of the floor instead: the ASE falls drive the 0.74 m sword
    up to 39 cm into the floor while lying, and lifting the body by that left it floating, 24 cm
    above the floor with no support -- a gravity finding of the audit).
    ``ballistic``: the lift adds no vertical acceleration on the frames where the lifted body is
    unsupported (:func:`unsupported_frames`: no effector touching and no body point resting on the
    floor): over each such run it is the straight line between its values at the supported frames
    on either side (after the last supported frame: held), so the lift's change of speed happens
    where the floor can push (a falling body whose lift eased in mid-air fell at 3-6 m/s^2, then at
    13.7 m/s^2: gravity findings of the audit); never below what a frame needs. Three passes, the
    unsupported frames judged again on each pass's output."""
    P = motion.positions
    ends = motion.end_site_positions()
    keep = np.ones(motion.skeleton.n_joints, bool)
    keep[list(exclude)] = False
    low = P[:, keep, 1].min(axis=1)
    if ends.size:
        ek = [k for k, e in enumerate(motion.skeleton.end_sites) if keep[e.parent]]
        if ek:
            low = np.minimum(low, ends[:, ek, 1].min(axis=1))
    need = np.maximum(floor_y - tolerance - low, 0.0)
    if not need.any():
        return motion, np.zeros(motion.n_frames)
    r = int(np.ceil(3 * smooth_frames))
    lift = gaussian_filter1d(maximum_filter1d(need, 2 * r + 1, mode="nearest"), smooth_frames, mode="nearest")
    if start > 0 or ramp_frames > 0:
        from ..ops import ease

        k = np.arange(motion.n_frames) - start
        w = ease(np.clip(k / max(ramp_frames, 1), 0.0, 1.0), "smoothstep") if ramp_frames > 0 else (k >= 0) * 1.0
        w[k < 0] = 0.0
        lift = lift * w
    need = need if start <= 0 else np.where(np.arange(motion.n_frames) >= start, need, 0.0)
    lift = np.maximum(lift, need)
    lift[lift < 1e-6] = 0.0
    rp = np.array(motion.root_positions)
    if ballistic:
        prev = None
        for _ in range(3):
            trial = np.array(rp)
            trial[:, 1] += lift
            air = unsupported_frames(motion.replace(root_positions=trial), floor_y)
            if prev is not None and np.array_equal(air, prev):
                break
            prev = air
            lift = np.maximum(linear_over(lift, air, start), need)
            lift[lift < 1e-6] = 0.0
    rp[:, 1] += lift
    return motion.replace(root_positions=rp), lift


def unsupported_frames(motion: Motion, floor_y: float, *, clearance: float = 0.08) -> np.ndarray:
    """``(T,)`` bool: frames on which nothing holds the body up, judged as :func:`mocomp.audit.audit`
    judges its flights: no end effector touching (:func:`~mocomp.dynamics.contacts.detect_contacts`,
    :func:`~mocomp.dynamics.contacts.airborne_intervals`) and the body's lowest point (any joint or
    end site) not resting within ``clearance`` m of ``floor_y``
    (:func:`mocomp.audit.contacts.body_support`, the audit's ``support_clearance``)."""
    from ..audit.contacts import body_points, body_support, lowest_points
    from ..dynamics.contacts import airborne_intervals, detect_contacts

    T = motion.n_frames
    contacts = detect_contacts(motion)
    air = np.zeros(T, bool)
    for a, b in airborne_intervals(contacts, min_frames=1):
        air[a:b] = True
    if not air.any():
        return air
    pts = body_points(motion)
    low, low_i, _ = lowest_points(motion, pts)
    return air & ~body_support(pts[0], motion.fps, low, low_i, floor_y, clearance, contacts.speed_tol)


def ballistic_com(motion: Motion, body, floor_y: float, *, start: int = 0, stop: int | None = None,
                  g: float = 9.81, clearance: float = 0.08, min_com_height: float = 0.45,
                  passes: int = 2) -> tuple[Motion, np.ndarray]:
    """``(motion, shift (T, 3) m)``: the root translated on each run of free-fall frames inside
    ``[start, stop)`` so that the whole-body COM (``body``'s segment masses,
    :func:`mocomp.dynamics.com.segment_positions`) falls freely there: from its position at the frame
    before the run to its position at the frame after it, straight horizontally and a parabola of
    acceleration ``-g`` (m/s^2) vertically, ``c_a + (c_b - c_a) t / D + (0, g t (D - t) / 2, 0)``.
    Free-fall frames: :func:`unsupported_frames`, no body point within ``clearance`` m of the floor
    (a body sliding on its hip is held by the floor however fast it slides) and the COM at least
    ``min_com_height`` m above it (the audit's ``flight_com_height``: lower, the body lies on the
    floor). The pose is kept, so the angular momentum about the COM is not changed. Runs whose ends
    fall outside ``[start, stop)`` or the clip are left alone. The final blend's root (a weighted mean
    of the simulated and the found clip's roots, each falling on its own timeline) is not ballistic
    where both are; this distributes the root correction over the frames the floor can push on.
    ``passes``: the free-fall frames judged again on the shifted motion."""
    from ..audit.contacts import lowest_points
    from ..dynamics.com import segment_positions

    T = motion.n_frames
    stop = T if stop is None else min(int(stop), T)
    shift = np.zeros((T, 3))
    m = np.asarray(body.masses, float)
    for _ in range(max(int(passes), 1)):
        com = np.einsum("s,tsk->tk", m, segment_positions(body, motion)) / m.sum()
        low = lowest_points(motion)[0]
        air = unsupported_frames(motion, floor_y, clearance=clearance)
        air &= (low - floor_y > clearance) & (com[:, 1] - floor_y >= min_com_height)
        air[:max(start, 0)] = False
        air[stop:] = False
        if not air.any():
            break
        rp = np.array(motion.root_positions)
        changed = False
        for k, b in label_intervals(air):
            a = k - 1
            if a >= max(start, 0) and b < stop and b - a >= 2:
                D = (b - a) / motion.fps
                t = (np.arange(a + 1, b) - a) / motion.fps
                path = com[a] + (com[b] - com[a]) * (t / D)[:, None]
                path[:, 1] += 0.5 * g * t * (D - t)
                d = path - com[a + 1:b]
                if np.abs(d).max() > 1e-9:
                    rp[a + 1:b] += d
                    shift[a + 1:b] += d
                    changed = True
        if not changed:
            break
        motion = motion.replace(root_positions=rp)
    return motion, shift


def linear_over(values: np.ndarray, mask: np.ndarray, start: int = 0) -> np.ndarray:
    """``values (T,)`` made straight over each run of ``mask`` frames at or after ``start``: the line
    from the last frame before the run (not before ``start - 1``) to the first after it, or held at
    the last frame's value when the run ends the array. Its second difference is zero on every
    ``mask`` frame (the audit's central-difference acceleration over a flight)."""
    out = np.array(values, dtype=float)
    T = out.size
    m = np.array(mask, bool)
    m[:max(start, 0)] = False
    for k, b in label_intervals(m):
        a = max(k - 1, start - 1, 0)
        if b < T:
            out[a:b + 1] = np.linspace(out[a], out[b], b - a + 1)
        else:
            out[a:] = out[a]
    return out


def props_above_floor(motion: Motion, floor_y: float, props: tuple[int, ...], *, tolerance: float = 0.005,
                      smooth_frames: float = 2.0, start: int = 0) -> tuple[Motion, np.ndarray]:
    """``(motion, angle (T,) rad)``: each prop of ``props`` (:func:`wrist_props`) kept no more than
    ``tolerance`` m below ``floor_y`` by turning its parent (the wrist) in the vertical plane of the
    hand-to-prop line: the line's drop is limited to what the floor allows, the deficit smoothed in
    time like :func:`floor_lift`'s (a running maximum, then a Gaussian: never less than a frame
    needs), the turn the shortest arc from the line to its lifted copy. Frames before ``start`` are
    left alone. ``angle``: the largest turn over the props per frame."""
    from ..core.rotations import quat_inverse, quat_multiply, shortest_arc

    T = motion.n_frames
    angle = np.zeros(T)
    if not props or T == 0:
        return motion, angle
    parents = np.asarray(motion.skeleton.parents)
    rot = np.array(motion.rotations)
    r = int(np.ceil(3 * smooth_frames))
    for j in props:
        P = motion.positions
        G = motion.global_rotations
        h = int(parents[j])
        v = P[:, j] - P[:, h]
        L = np.linalg.norm(v, axis=1)
        lo = floor_y - tolerance - P[:, h, 1]              # the lowest the line may reach
        need = np.maximum(lo - v[:, 1], 0.0)
        need[:start] = 0.0
        if not need.any():
            continue
        d = gaussian_filter1d(maximum_filter1d(need, 2 * r + 1, mode="nearest"), smooth_frames, mode="nearest")
        d = np.maximum(d, need)
        d[:start] = 0.0
        d[d < 1e-6] = 0.0
        y = np.clip(v[:, 1] + d, -L, L)
        hor = v[:, [0, 2]]
        hn = np.linalg.norm(hor, axis=1)
        dirs = np.where(hn[:, None] > 1e-9, hor / np.maximum(hn, 1e-9)[:, None], np.array([1.0, 0.0]))
        hl = np.sqrt(np.maximum(L ** 2 - y ** 2, 0.0))
        w = np.stack([dirs[:, 0] * hl, y, dirs[:, 1] * hl], axis=1)
        q = shortest_arc(v, w)                             # world turn of the line
        q[d == 0] = (0.0, 0.0, 0.0, 1.0)
        gp = G[:, int(parents[h])] if parents[h] >= 0 else np.broadcast_to((0.0, 0.0, 0.0, 1.0), (T, 4))
        # new local = parent^-1 q G_h
        rot[:, h] = quat_multiply(quat_inverse(gp), quat_multiply(q, G[:, h]))
        motion = motion.replace(rotations=rot)
        rot = np.array(motion.rotations)
        cosang = np.clip(np.einsum("ij,ij->i", v, w) / np.maximum(L * L, 1e-12), -1.0, 1.0)
        angle = np.maximum(angle, np.where(d > 0, np.arccos(cosang), 0.0))
    return motion, angle


def keep_before(changed: Motion, original: Motion, start: int, ramp_frames: int) -> tuple[Motion, int]:
    """``(motion, frames_restored)``: ``changed`` with the frames before ``start`` put back to
    ``original``'s exactly, the change easing in (smoothstep; root lerp, joints slerp) over the
    ``ramp_frames`` frames from ``start``. The plants (:func:`plant_feet`) hold the detector's plants of
    the whole output, the input clip's before the rewind frame too: on the running victim they raised a
    plant 1.7 cm over frames 0-24, which raised the audit's floor (measured from the first ground stage)
    above the input's own unchanged footfall at frame 31 (1.17 cm "penetration")."""
    from ..ops import ease

    if start <= 0 or changed.n_frames != original.n_frames:
        return changed, 0
    T = changed.n_frames
    k = np.arange(T) - start
    w = ease(np.clip((k + 1) / max(ramp_frames + 1, 1), 0.0, 1.0), "smoothstep") if ramp_frames > 0 else (k >= 0) * 1.0
    w = np.where(k < 0, 0.0, w)
    if np.all(w >= 1.0):
        return changed, 0
    rp = original.root_positions + w[:, None] * (changed.root_positions - original.root_positions)
    rot = slerp(original.rotations, changed.rotations, np.broadcast_to(w[:, None], changed.rotations.shape[:2]))
    s = min(start, T)
    moved = int((np.any(np.abs(changed.root_positions[:s] - original.root_positions[:s]) > 1e-9, axis=1)
                 | np.any(np.abs(changed.rotations[:s] - original.rotations[:s]) > 1e-9, axis=(1, 2))).sum())
    return changed.replace(root_positions=rp, rotations=rot), moved


def plant_feet(motion: Motion, fade: float | None = None):
    """:func:`mocomp.ops.enforce_footplants` of ``motion`` (the detector's plants; no audits), each
    correction faded in and out over ``fade`` s (default: ops' 0.1 s). A longer fade (0.25 s) was
    tried against the foot turns the plants add near the re-entry (up to 33 deg in a frame after a
    side hit): it halved them but made joint-speed violations elsewhere."""
    from ..ops import enforce_footplants

    blend = None if fade is None else max(1, int(round(fade * motion.fps)))
    return enforce_footplants(motion, audit=False, blend=blend)


def limit_plant_steps(before: Motion, after: Motion, plants, max_step: float, *, iterations: int = 14,
                      free: np.ndarray | None = None):
    """``(motion, frames_limited)``: ``after`` (``before`` with its feet planted, :func:`plant_feet`)
    with the plants' leg corrections slowed down outside the planted frames, so that no leg joint
    turns further in one frame than ``max(its own step in before, max_step)`` (rad).

    The plants change the hip, knee and ankle rotations of a leg (``after = before * c``, ``c`` the
    local correction) and fade that correction in and out over a fixed time (ops' 0.1 s); a plant
    that starts right after the re-entry seam, where the blended segment's foot is far from the
    clip's, turned the ankle up to 38 deg in a frame (the found clip's own largest step: 15.6 deg).
    Here the correction of each leg joint is rate-limited outside its leg's planted frames, in a
    forward and a backward pass: where a frame's output step exceeds the limit, its correction is
    moved along the arc toward the neighbour's (which gives exactly the input's own step) as far as
    the limit allows (bisection on the arc). Planted frames keep their correction exactly, so the
    plants stay held; only the fades get longer where they were too fast.
    ``plants``: the :class:`~mocomp.ops.plants.FootPlants` the correction enforced. ``free``: ``(T,)``
    bool, frames where the leg joints are limited even when planted (the plant there gives way to the
    limit: a foot held by its toe across the re-entry while the blended foot slides under it)."""
    from ..core.rotations import slerp as _slerp

    qb = np.asarray(before.rotations, float)
    qa = np.asarray(after.rotations, float)
    T, J = qb.shape[:2]
    c = quat_multiply(quat_inverse(qb), qa)
    planted = np.ones((T, J), bool)                      # joints no plant moves are never touched
    names = tuple(plants.effectors)
    for leg in plants.legs:
        cols = [names.index(e) for e in (f"foot_{leg.side}", f"toe_{leg.side}") if e in names]
        held = plants.labels[:, cols].any(axis=1) if cols else np.zeros(T, bool)
        if free is not None:
            held = held & ~np.asarray(free, bool)
        for j in leg.chain:
            planted[:, j] = held
    own = np.zeros((T, J))
    own[1:] = quat_angle(quat_multiply(quat_inverse(qb[:-1]), qb[1:]))
    touched = np.zeros(T, bool)

    def gap(m, cm, k, ck, idx):                          # angle between frame m's and frame k's output
        return quat_angle(quat_multiply(quat_inverse(quat_multiply(qb[m, idx], cm)), quat_multiply(qb[k, idx], ck)))

    allj = np.arange(J)

    def sweep(order, nb):
        for k in order:
            m = nb(k)
            free = ~planted[k]
            if not free.any():
                continue
            lim = np.maximum(own[max(k, m)], max_step) + 1e-9
            over = free & (gap(m, c[m], k, c[k], allj) > lim)
            if not over.any():
                continue
            idx = np.nonzero(over)[0]
            lo, hi = np.zeros(len(idx)), np.ones(len(idx))   # t: 0 = the neighbour's correction, 1 = own
            for _ in range(iterations):
                t = 0.5 * (lo + hi)
                ok = gap(m, c[m, idx], k, _slerp(c[m, idx], c[k, idx], t), idx) <= lim[idx]
                lo = np.where(ok, t, lo)
                hi = np.where(ok, hi, t)
            c[k, idx] = _slerp(c[m, idx], c[k, idx], lo)
            touched[k] = True

    sweep(range(1, T), lambda k: k - 1)
    sweep(range(T - 2, -1, -1), lambda k: k + 1)
    if not touched.any():
        return after, 0
    rot = quat_multiply(qb, c)
    return after.replace(rotations=rot), int(touched.sum())
