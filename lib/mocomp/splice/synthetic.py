"""Ground truth for hand/body splicing (dissertation ch. 6): pairs of recordings
whose true frame correspondence is known.

A *hand recording* (a real gesture clip such as the Bandai Namco waving
clips, or a procedural gesture script) is turned into a *body recording* of
the same gesture by

* a known, non-uniform, monotone time warp ``s(i)`` (body frame ``i`` shows
  hand frame ``s(i)``: the truth the alignment must recover);
* a time-varying amplitude change ``a(i)`` in ``[0.5, 1.5]``: the upper-arm and
  elbow rotations about their mean pose are scaled,
  ``q = q_mean exp(a log(q_mean^-1 q))``, so the hand swings wider or narrower
  about the shoulder (the wrist's own posture is left as recorded);
* a different body motion underneath (a walk) that drives every other joint;
* white rotation noise on the arm joints, ``DEFAULT_NOISE_DEG = 0.25`` degrees
  per axis and frame by default.

The noise level is calibrated, not guessed: :func:`~mocomp.splice.metrics.marker_jitter`
(white-noise estimate from the residual of a 5-frame cubic fit) gives
0.06-0.25 mm on the virtual hand markers of the real clips in the data folder
(Bandai Namco gestures and walk at 30 Hz, CMU wave at 60 Hz; an upper bound,
since fast motion also leaves a residual), and about 2.4 mm with 0.25 degrees
of rotation noise: ten times the noisiest real clip, the order of raw optical
marker noise. The earlier default of 1 degree gives about 9.3 mm, 40 times
the real clips; it stays available as a stress test (the sign metric of eq.
6.6 compares signs of derivatives, so it is the first to suffer from noise).

Everything is seeded by a ``numpy.random.Generator`` or an int.

Without data files, :func:`gesture_clip` writes gesture scripts in the phase
vocabulary of Table 6.1 (rest, preparation, strokes, hold, retraction) on
:func:`gesture_skeleton`, and :func:`walk_clip` a procedural walk on it.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.ndimage import gaussian_filter1d
from scipy.spatial.transform import Rotation

from ..core.motion import Motion, SourceInfo
from ..core.skeleton import EndSite, Skeleton
from ..errors import AlignmentError
from .markers import find_arm_joints

__all__ = [
    "DEFAULT_NOISE_DEG",
    "gesture_skeleton",
    "GestureClip",
    "gesture_clip",
    "walk_clip",
    "time_warp",
    "amplitude_profile",
    "SplicePair",
    "make_splice_pair",
    "synthetic_pair",
    "embedded_pair",
    "ambiguous_pair",
    "scale_arm_amplitude",
    "turn_about_vertical",
    "MarkerPair",
    "make_marker_pair",
]


#: default rotation noise of the body recording, degrees per axis and frame (see the module docstring)
DEFAULT_NOISE_DEG = 0.25


# ------------------------------------------------------------- the performer
def gesture_skeleton(height: float = 1.70) -> Skeleton:
    """A 21-joint humanoid with the Bandai Namco joint names (``Hips``, ``Spine``,
    ``Chest``, ``Shoulder_R``, ``UpperArm_R``, ``LowerArm_R``, ``Hand_R``, ...).

    Rest pose: T-pose, y-up, facing +z, the performer's left on +x. Segment
    lengths as fractions of ``height``: upper arm 0.172, forearm 0.150, hand
    (wrist to knuckles) 0.050, thigh 0.2425, shank 0.2525 (de Leva 1996
    proportions); the soles are at ``y = 0``.
    """
    H = float(height)
    J = [
        ("Hips", None, (0, 0.575 * H, 0)),
        ("Spine", "Hips", (0, 0.06 * H, 0)),
        ("Chest", "Spine", (0, 0.12 * H, 0)),
        ("Neck", "Chest", (0, 0.085 * H, 0)),
        ("Head", "Neck", (0, 0.07 * H, 0)),
        ("Shoulder_L", "Chest", (0.02 * H, 0.06 * H, 0)),
        ("UpperArm_L", "Shoulder_L", (0.085 * H, 0, 0)),
        ("LowerArm_L", "UpperArm_L", (0.172 * H, 0, 0)),
        ("Hand_L", "LowerArm_L", (0.150 * H, 0, 0)),
        ("Shoulder_R", "Chest", (-0.02 * H, 0.06 * H, 0)),
        ("UpperArm_R", "Shoulder_R", (-0.085 * H, 0, 0)),
        ("LowerArm_R", "UpperArm_R", (-0.172 * H, 0, 0)),
        ("Hand_R", "LowerArm_R", (-0.150 * H, 0, 0)),
        ("UpperLeg_L", "Hips", (0.052 * H, -0.041 * H, 0)),
        ("LowerLeg_L", "UpperLeg_L", (0, -0.2425 * H, 0)),
        ("Foot_L", "LowerLeg_L", (0, -0.2525 * H, 0)),
        ("Toes_L", "Foot_L", (0, -0.027 * H, 0.08 * H)),
        ("UpperLeg_R", "Hips", (-0.052 * H, -0.041 * H, 0)),
        ("LowerLeg_R", "UpperLeg_R", (0, -0.2425 * H, 0)),
        ("Foot_R", "LowerLeg_R", (0, -0.2525 * H, 0)),
        ("Toes_R", "Foot_R", (0, -0.027 * H, 0.08 * H)),
    ]
    names = [j[0] for j in J]
    parents = [-1 if p is None else names.index(p) for _, p, _ in J]
    offsets = np.array([o for *_, o in J], dtype=float)
    ends = (
        EndSite(names.index("Head"), (0, 0.09 * H, 0), "Head_end"),
        EndSite(names.index("Hand_L"), (0.05 * H, 0, 0), "Hand_L_end"),
        EndSite(names.index("Hand_R"), (-0.05 * H, 0, 0), "Hand_R_end"),
        EndSite(names.index("Toes_L"), (0, 0, 0.04 * H), "Toes_L_end"),
        EndSite(names.index("Toes_R"), (0, 0, 0.04 * H), "Toes_R_end"),
    )
    return Skeleton(tuple(names), np.array(parents), offsets, None, ends)


def _rot(axis: str, deg) -> Rotation:
    deg = np.asarray(deg, dtype=float)
    return Rotation.from_euler(axis, deg[..., None] if deg.ndim else deg, degrees=True)


def _arm_quats(pose: np.ndarray, side: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Local quaternions of upper arm, forearm, hand from ``pose (T, 6)`` =
    (elevation, flexion, twist, elbow, wrist flexion, wrist deviation) in degrees.

    Elevation 90 = arm horizontal to the side (T-pose), 0 = hanging down;
    flexion swings the arm forward; the right arm's rest direction is -x.
    The left arm is the mirror image (rotations about y and z change sign).
    """
    s = 1.0 if side == "right" else -1.0
    e, f, t, b, w, d = pose.T
    upper = _rot("y", s * f) * _rot("z", s * (90.0 - e)) * _rot("x", t)
    fore = _rot("y", s * b)
    hand = _rot("y", s * w) * _rot("z", s * d)
    return upper.as_quat(), fore.as_quat(), hand.as_quat()


def _minjerk(u):
    u = np.clip(u, 0.0, 1.0)
    return u ** 3 * (10 - 15 * u + 6 * u ** 2)


REST_POSE = np.array([8.0, 5.0, 0.0, 15.0, 0.0, 0.0])


@dataclass(frozen=True, eq=False)
class GestureClip:
    """A procedural gesture recording.

    Attributes
    ----------
    motion: the clip (standing still, one arm gesturing).
    labels: ``(T,)`` Table 6.1 label of every frame as scripted (``"H"`` also for rest).
    pose: ``(T, 6)`` the arm pose parameters (degrees) that drove it.
    cycle_starts: first frame of each gesture.
    side: the gesturing arm.
    strokes: ``(start, stop)`` frames of every scripted individual stroke: each
        beat of a stroke phase swings out and back, so a phase of ``c`` beats
        holds ``2 c`` strokes, one per movement between reversals of direction.
    """

    motion: Motion
    labels: np.ndarray
    pose: np.ndarray
    cycle_starts: tuple[int, ...]
    side: str
    strokes: tuple[tuple[int, int], ...] = ()


def _random_gesture(rng: np.random.Generator) -> dict:
    target = np.array([rng.uniform(45, 100), rng.uniform(15, 70), rng.uniform(-30, 30),
                       rng.uniform(45, 105), rng.uniform(-20, 20), rng.uniform(-10, 10)])
    return dict(
        target=target,
        t_prep=rng.uniform(0.8, 1.2),
        strokes=int(rng.integers(1, 4)),
        stroke_hz=rng.uniform(2.0, 3.0),
        amp=np.array([rng.uniform(-8, 8), rng.uniform(-10, 10), 0.0, rng.uniform(20, 35), rng.uniform(15, 30), 0.0]),
        t_hold=rng.uniform(0.25, 0.5),
        t_ret=rng.uniform(0.8, 1.2),
        t_rest=rng.uniform(0.3, 0.5),
    )


def _gesture_script(rng: np.random.Generator, n_gestures: int, periodic: bool, coda: bool):
    """Segments (gesture index, label, duration s, start pose, end pose, strokes spec)."""
    segs = []
    specs = [_random_gesture(rng)]
    for g in range(1, n_gestures):
        specs.append(specs[0] if periodic else _random_gesture(rng))
    if coda:
        specs.append(_random_gesture(rng))
    for g, spec in enumerate(specs):
        if g == 0 or not periodic:  # periodic cycles follow each other without a rest
            segs.append((g, "H", spec["t_rest"], REST_POSE, REST_POSE, None))
        segs.append((g, "P", spec["t_prep"], REST_POSE, spec["target"], None))
        segs.append((g, "S", spec["strokes"] / spec["stroke_hz"], spec["target"], spec["target"], (spec["strokes"], spec["amp"])))
        segs.append((g, "H", spec["t_hold"], spec["target"], spec["target"], None))
        segs.append((g, "R", spec["t_ret"], spec["target"], REST_POSE, None))
    segs.append((len(specs) - 1, "H", 0.4, REST_POSE, REST_POSE, None))
    return segs


def gesture_clip(rng=0, n_gestures: int = 4, fps: float = 30.0, side: str = "right", *,
                 skeleton: Skeleton | None = None, periodic: bool = False, coda: bool = False,
                 idle_deg: float = 2.0) -> GestureClip:
    """A standing performer making ``n_gestures`` gestures with one arm.

    Each gesture is scripted as rest, preparation (minimum-jerk move to a
    random pose in the gesture space), 1-3 strokes (beats of elbow and wrist at
    2-3 Hz), hold, retraction to the rest pose (Table 6.1 phases).
    A slow idle drift of ``idle_deg`` degrees (smoothed noise, 0.4 s
    correlation) on shoulder elevation, elbow and wrist keeps holds from being
    perfectly static. ``periodic=True`` repeats the first gesture's script
    back to back (a "counting" motion: cycles identical up to the idle drift,
    the ambiguous case for alignment); ``coda=True`` appends one more, different
    gesture. ``cycle_starts`` holds each gesture's first frame.
    """
    rng = np.random.default_rng(rng)
    sk = skeleton or gesture_skeleton()
    segs = _gesture_script(rng, n_gestures, periodic, coda)
    poses, labels, starts, stroke_bounds = [], [], [], []
    t_carry = 0.0
    for k, (g, lab, dur, p0, p1, strokes) in enumerate(segs):
        n = max(1, int(round((dur + t_carry) * fps)))
        t_carry += dur - n / fps
        u = (np.arange(n) + 1) / n
        if k == 0 or g != segs[k - 1][0]:
            starts.append(len(labels) + 1)
        if strokes is None:
            pose = p0 + (p1 - p0) * _minjerk(u)[:, None]
        else:
            count, amp = strokes
            pose = p0 + amp[None, :] * (0.5 - 0.5 * np.cos(2 * np.pi * count * u))[:, None]
            first = len(labels) + 1  # frame 0 is the initial rest frame
            cuts = [first + int(round(k * n / (2 * count))) for k in range(2 * count + 1)]
            stroke_bounds += list(zip(cuts[:-1], cuts[1:]))
        poses.append(pose)
        labels += [lab] * n
    pose = np.concatenate([REST_POSE[None], *poses])
    labels = np.array(["H"] + labels)
    T = len(pose)
    if idle_deg > 0:  # nobody holds perfectly still: slow drift of shoulder, elbow and wrist
        for c in (0, 3, 4):
            pose[:, c] += idle_deg * _smooth_noise(T, rng, 0.4 * fps)
    q = np.zeros((T, sk.n_joints, 4))
    q[..., 3] = 1.0
    arm = find_arm_joints(sk, side)
    other = find_arm_joints(sk, "left" if side == "right" else "right")
    qu, qf, qh = _arm_quats(pose, side)
    q[:, arm.upper], q[:, arm.forearm], q[:, arm.hand] = qu, qf, qh
    rest = np.repeat(REST_POSE[None], T, axis=0)
    ou, of, oh = _arm_quats(rest, other.side)
    q[:, other.upper], q[:, other.forearm], q[:, other.hand] = ou, of, oh
    root = np.repeat(sk.offsets[:1], T, axis=0)
    m = Motion(sk, fps, root, q, SourceInfo(format="synthetic", notes=(f"gesture_clip({n_gestures} gestures, {side} arm, periodic={periodic})",)))
    return GestureClip(m, labels, pose, tuple(starts), side, tuple(stroke_bounds))


def walk_clip(n_frames: int, fps: float = 30.0, *, skeleton: Skeleton | None = None, speed: float = 1.2,
              cadence: float = 0.9, heading_deg: float = 0.0) -> Motion:
    """A procedural straight walk (``cadence`` gait cycles per second): the
    pelvis bobs and sways, pelvis and chest counter-rotate (+-6 deg / -+4 deg),
    legs and arms swing. Not physically exact; it only has to move the trunk
    and shoulders underneath a spliced arm."""
    sk = skeleton or gesture_skeleton()
    t = np.arange(n_frames) / fps
    ph = 2 * np.pi * cadence * t
    yaw0 = np.radians(heading_deg)
    fwd = np.array([np.sin(yaw0), 0.0, np.cos(yaw0)])
    side = np.array([np.cos(yaw0), 0.0, -np.sin(yaw0)])
    root = sk.offsets[0][None, :] + speed * t[:, None] * fwd[None, :]
    root = root + (0.02 * np.cos(2 * ph))[:, None] * np.array([0, 1.0, 0]) + (0.02 * np.sin(ph))[:, None] * side[None, :]
    q = np.zeros((n_frames, sk.n_joints, 4))
    q[..., 3] = 1.0
    idx = sk.index
    q[:, idx("Hips")] = (_rot("y", np.degrees(yaw0) + 6 * np.sin(ph))).as_quat()
    q[:, idx("Chest")] = _rot("y", -10 * np.sin(ph)).as_quat()
    for name, sgn in (("UpperLeg_L", 1.0), ("UpperLeg_R", -1.0)):
        q[:, idx(name)] = _rot("x", -25 * sgn * np.sin(ph)).as_quat()
    for name, lag in (("LowerLeg_L", 0.0), ("LowerLeg_R", np.pi)):
        q[:, idx(name)] = _rot("x", 35 * np.maximum(0.0, np.sin(ph - lag))).as_quat()
    for s, sgn in (("left", 1.0), ("right", -1.0)):
        pose = np.repeat(REST_POSE[None], n_frames, axis=0).copy()
        pose[:, 1] = 5 + 18 * sgn * np.sin(ph)
        pose[:, 3] = 20 + 8 * sgn * np.sin(ph)
        arm = find_arm_joints(sk, s)
        qu, qf, qh = _arm_quats(pose, s)
        q[:, arm.upper], q[:, arm.forearm], q[:, arm.hand] = qu, qf, qh
    return Motion(sk, fps, root, q, SourceInfo(format="synthetic", notes=(f"walk_clip({speed} m/s, {cadence} Hz)",)))


# ------------------------------------------------------------ warps, amplitude
def _smooth_noise(n: int, rng: np.random.Generator, sigma: float) -> np.ndarray:
    x = gaussian_filter1d(rng.normal(size=n + 8 * int(sigma) + 8), sigma, mode="wrap")[4 * int(sigma) + 4:][:n]
    x = x - x.mean()
    sd = x.std()
    return x / sd if sd > 0 else x


def time_warp(n: int, m: int, rng=0, strength: float = 0.5, smoothness: float = 0.08) -> np.ndarray:
    """A smooth, strictly increasing map ``s (n,)`` from body frames to hand
    frames with ``s(0) = 0`` and ``s(n-1) = m-1``.

    The local playback speed is ``exp(strength * z(i))`` with ``z`` unit-variance
    Gaussian-smoothed noise (correlation length ``smoothness * n`` frames);
    ``strength = 0.5`` gives speeds of about 0.4x-2.7x around the mean ``(m-1)/(n-1)``.
    """
    if n < 2 or m < 2:
        raise AlignmentError("a time warp needs at least 2 frames on each side")
    rng = np.random.default_rng(rng)
    speed = np.exp(strength * _smooth_noise(n - 1, rng, max(1.0, smoothness * n)))
    s = np.concatenate([[0.0], np.cumsum(speed)])
    return s * (m - 1) / s[-1]


def amplitude_profile(n: int, rng=0, low: float = 0.5, high: float = 1.5, smoothness: float = 0.1) -> np.ndarray:
    """A smooth amplitude factor ``(n,)`` spanning exactly ``[low, high]``."""
    rng = np.random.default_rng(rng)
    z = _smooth_noise(n, rng, max(1.0, smoothness * n))
    z = (z - z.min()) / max(np.ptp(z), 1e-12)
    return low + (high - low) * z


def _arm_chain(sk: Skeleton, side: str) -> list[int]:
    arm = find_arm_joints(sk, side)
    chain = ([arm.clavicle] if arm.clavicle is not None else []) + [arm.upper, arm.forearm, arm.hand]
    # and everything below the hand (fingers)
    below = [j for j in range(sk.n_joints) if arm.hand in sk.chain(j) and j != arm.hand]
    return chain + below


def scale_arm_amplitude(rotations: np.ndarray, joints: list[int], factor: np.ndarray,
                        reference: np.ndarray | None = None) -> np.ndarray:
    """Scale each joint's rotation about a reference pose by ``factor (T,)``:
    ``q = q_ref exp(a log(q_ref^-1 q))`` (``q_ref``: the joint's mean rotation unless given)."""
    out = np.array(rotations, copy=True)
    a = np.asarray(factor, float)[:, None]
    for k, j in enumerate(joints):
        R = Rotation.from_quat(out[:, j])
        ref = R.mean() if reference is None else Rotation.from_quat(reference[k])
        dev = (ref.inv() * R).as_rotvec()
        out[:, j] = (ref * Rotation.from_rotvec(a * dev)).as_quat()
    return out


@dataclass(frozen=True, eq=False)
class SplicePair:
    """A body recording and a hand recording with their true correspondence.

    Attributes
    ----------
    body: the full-body recording (``n`` frames).
    hand: the hand recording (``m`` frames).
    truth: ``(n,)`` hand frame shown by each body frame (fractional).
    amplitude: ``(n,)`` the amplitude factor applied in the body recording.
    side: the arm.
    points: suggested user matching points (body frame, hand frame) on the truth.
    description: what was generated, with its parameters.
    """

    body: Motion
    hand: Motion
    truth: np.ndarray
    amplitude: np.ndarray
    side: str
    points: tuple = ()
    description: str = ""
    params: dict = field(default_factory=dict)


def _fit_length(under: Motion, n: int) -> Motion:
    if under.n_frames >= n:
        return under[:n]
    return under.sample(np.linspace(0.0, under.duration, n))


def make_splice_pair(hand: Motion, under: Motion, rng=0, *, n_body: int | None = None, side: str = "right",
                     warp: np.ndarray | None = None, warp_strength: float = 0.5,
                     amplitude: tuple[float, float] | np.ndarray = (0.5, 1.5), noise_deg: float = DEFAULT_NOISE_DEG,
                     heading_deg: float | np.ndarray = 0.0, amplitude_about: str = "mean") -> SplicePair:
    """Build a body recording of ``hand``'s gesture on top of ``under`` (e.g. a walk).

    The body clip has ``n_body`` frames (default ``1.2 m``) at ``hand.fps``:
    ``under``'s motion (cropped or stretched to that length) with the arm chain
    (clavicle, upper arm, forearm, hand and below) taken from ``hand`` at the
    warped frames ``truth = warp`` (default :func:`time_warp`), scaled about
    its mean pose by the amplitude profile (or the given per-frame factors;
    upper arm and elbow only; about the joints' mean rotation over the hand
    clip, or with ``amplitude_about="first"`` about its first frame, so a
    gesture that starts from rest still starts from rest when performed wider)
    and perturbed by white rotation noise of ``noise_deg`` degrees per axis
    (every arm-chain joint, every frame).
    ``hand`` and ``under`` need the same arm joint names.

    ``heading_deg`` (degrees, a number or ``(m,)`` per hand frame) turns the
    returned *hand* recording about the vertical through its first root
    position (root rotation and root path; the body recording, built before,
    and the truth are unchanged): a hand capture facing elsewhere than the
    body capture, or turning, which the alignment must be invariant to.
    """
    rng = np.random.default_rng(rng)
    m = hand.n_frames
    n = int(round(1.2 * m)) if n_body is None else int(n_body)
    if abs(under.fps - hand.fps) > 1e-6:
        under = under.resample(hand.fps)
    body0 = _fit_length(under, n)
    truth = time_warp(n, m, rng, warp_strength) if warp is None else np.asarray(warp, float)
    if truth.shape != (n,):
        raise AlignmentError(f"warp must have {n} entries, got {truth.shape}")
    amp = amplitude_profile(n, rng, *amplitude) if isinstance(amplitude, tuple) else np.asarray(amplitude, float)
    chain_h = _arm_chain(hand.skeleton, side)
    names = [hand.skeleton.names[j] for j in chain_h]
    missing = [nm for nm in names if nm not in body0.skeleton]
    if missing:
        raise AlignmentError(f"the body skeleton lacks the arm joints {missing}")
    chain_b = [body0.skeleton.index(nm) for nm in names]
    warped = hand.sample(truth / hand.fps)
    arm_rot = warped.rotations[:, chain_h]
    # amplitude about the shoulder: scale the upper arm and the elbow, not the
    # clavicle or the wrist/fingers (the hand's own posture is what the hand
    # capture records in detail)
    arm = find_arm_joints(hand.skeleton, side)
    scaled_idx = [chain_h.index(arm.upper), chain_h.index(arm.forearm)]
    if amplitude_about == "mean":
        ref = np.stack([Rotation.from_quat(hand.rotations[:, chain_h[k]]).mean().as_quat() for k in scaled_idx])
    elif amplitude_about == "first":
        ref = np.stack([hand.rotations[0, chain_h[k]] for k in scaled_idx])
    else:
        raise AlignmentError(f"amplitude_about must be 'mean' or 'first', got {amplitude_about!r}")
    scaled = arm_rot.copy()
    scaled[:, scaled_idx] = scale_arm_amplitude(arm_rot[:, scaled_idx], [0, 1], amp, ref)
    if noise_deg > 0:
        noise = Rotation.from_rotvec(np.radians(noise_deg) * rng.normal(size=(scaled.shape[0] * scaled.shape[1], 3)))
        scaled = (Rotation.from_quat(scaled.reshape(-1, 4)) * noise).as_quat().reshape(scaled.shape)
    rot = np.array(body0.rotations)
    rot[:, chain_b] = scaled
    body = body0.replace(rotations=rot, source=SourceInfo(format="synthetic", notes=(
        f"splice ground truth: arm of {hand.source.path or hand.source.format} warped onto {under.source.path or under.source.format}",)))
    head = np.broadcast_to(np.asarray(heading_deg, dtype=float), (m,)) if np.ndim(heading_deg) == 0 else np.asarray(heading_deg, float)
    if head.shape != (m,) or not np.all(np.isfinite(head)):
        raise AlignmentError(f"heading_deg must be a finite number or {m} finite values (one per hand frame), got shape {head.shape}")
    desc = (f"{side} arm of a {m}-frame hand clip on a {n}-frame body clip, warp strength {warp_strength}, "
            f"amplitude {amp.min():.2f}-{amp.max():.2f}, noise {noise_deg} deg")
    if np.any(head != 0):
        hand = turn_about_vertical(hand, head)
        desc += f", hand recording turned {head.min():g}-{head.max():g} deg about the vertical"
    return SplicePair(body, hand, truth, amp, side, (), desc,
                      {"warp_strength": warp_strength, "noise_deg": noise_deg, "n": n, "m": m,
                       "heading_deg": (float(head.min()), float(head.max()))})


def turn_about_vertical(motion: Motion, degrees: float | np.ndarray) -> Motion:
    """``motion`` turned about the vertical (y) axis through its first root
    position by ``degrees`` (a number or one per frame): root rotation
    ``R_y q_root`` and root path ``p_0 + R_y (p - p_0)``; local joint rotations unchanged."""
    T = motion.n_frames
    deg = np.broadcast_to(np.asarray(degrees, dtype=float), (T,))
    R = _rot("y", np.ascontiguousarray(deg))
    q = np.array(motion.rotations)
    q[:, 0] = (R * Rotation.from_quat(q[:, 0])).as_quat()
    p = np.array(motion.root_positions, dtype=float)
    p0 = p[:1] * np.array([1.0, 0.0, 1.0])
    return motion.replace(rotations=q, root_positions=p0 + R.apply(p - p0))


def synthetic_pair(rng=0, *, n_gestures: int = 4, fps: float = 30.0, side: str = "right", **kw) -> SplicePair:
    """A data-free ground-truth pair: :func:`gesture_clip` as the hand recording,
    spliced onto :func:`walk_clip` by :func:`make_splice_pair`."""
    rng = np.random.default_rng(rng)
    g = gesture_clip(rng, n_gestures, fps, side)
    n = kw.pop("n_body", None) or int(round(1.2 * g.motion.n_frames))
    walk = walk_clip(n, fps, skeleton=g.motion.skeleton)
    return make_splice_pair(g.motion, walk, rng, n_body=n, side=side, **kw)


def embedded_pair(rng=0, *, body_seconds: float = 20.0, hand_seconds: float = 3.0, start: float | None = None,
                  fps: float = 30.0, side: str = "right", rate: float = 1.1, blend: float = 0.5,
                  warp_strength: float = 0.3, **kw) -> SplicePair:
    """Ground truth for subsequence alignment (issue #19 item 9): a short hand
    recording performed somewhere inside a long body take.

    The hand recording is one :func:`gesture_clip` gesture, preparation to
    retraction (a trimmed take, without the rest before and after), played
    back over exactly ``hand_seconds`` (``m`` frames); the body recording is a
    ``body_seconds`` :func:`walk_clip` whose arm performs that gesture over
    body frames ``a .. a + k - 1`` (``k = round(rate m)``, starting at
    ``start`` seconds, default the middle) through :func:`make_splice_pair`
    (time warp, amplitude change, noise; ``kw`` passes on; the warp's and the
    amplitude's correlation lengths are those of a whole ``body_seconds``
    pair, 0.08 and 0.1 of the take; the warp's speed variation (``warp_strength``)
    tapers to a steady pace over the first and last 20 % of the interval; the amplitude is scaled about the
    gesture's first pose, the rest it starts from), and swings as in
    the walk elsewhere, easing into the gesture's first pose over ``blend``
    seconds before the interval and out of its last pose after it (minimum-jerk
    slerp). ``truth`` is NaN outside the interval;
    ``params["interval"] = (a, a + k - 1)``.
    """
    rng = np.random.default_rng(rng)
    g = gesture_clip(rng, 1, fps, side)
    moving = np.nonzero(g.labels != "H")[0]  # the gesture proper: preparation .. retraction, no rest
    g0, g1 = int(moving.min()), int(moving.max())
    m = int(round(hand_seconds * fps))
    hand = g.motion.sample(np.linspace(g0, g1, m) / fps)
    hand = hand.replace(source=SourceInfo(format="synthetic", notes=(f"one gesture played over {hand_seconds:g} s",)))
    n = int(round(body_seconds * fps))
    k = int(round(rate * m))
    if k >= n:
        raise AlignmentError(f"the gesture ({k} body frames) does not fit into a {n}-frame body take")
    a = (n - k) // 2 if start is None else int(round(start * fps))
    if not (0 <= a <= n - k):
        raise AlignmentError(f"start {start} s puts the gesture outside the {body_seconds:g} s body take")
    blend = int(round(blend * fps))
    walk = walk_clip(n, fps, skeleton=hand.skeleton)
    # warp and amplitude vary on the time scale of the whole take (as in make_splice_pair for a clip of n
    # frames), not of the short interval: a 3 s gesture is not played at 0.4x-2.7x within a third of a second
    warp = kw.pop("warp", None)
    strength = warp_strength
    if warp is None:
        # playback speed exp(strength z taper): the taper (0 at the interval's ends, 1 from 20 % in) makes the
        # body start and finish the gesture at one steady pace, so its ends are where the data put them (a
        # retraction slowed to a crawl over its last 20 frames cannot be told from a pause after it)
        z = _smooth_noise(k - 1, rng, max(1.0, 0.08 * n))
        u = np.minimum(np.arange(k - 1) + 0.5, k - 1.5 - np.arange(k - 1)) / (0.2 * (k - 1))
        speed = np.exp(strength * z * _minjerk(u))
        warp = np.concatenate([[0.0], np.cumsum(speed)]) * (m - 1) / np.sum(speed)
    amp = kw.pop("amplitude", (0.5, 1.5))
    if isinstance(amp, tuple):
        amp = amplitude_profile(n, rng, *amp)[a:a + k]
    kw.setdefault("amplitude_about", "first")
    sub = make_splice_pair(hand, walk[a:a + k], rng, n_body=k, side=side, warp=warp, amplitude=amp, **kw)
    rot = np.array(walk.rotations)
    rot[a:a + k] = sub.body.rotations
    # the walk's arm eases into the gesture's first pose before the interval and out of its last after it
    # (smoothstep slerp over ``blend`` frames), so the body's arm is continuous and the interval is the gesture
    chain = _arm_chain(hand.skeleton, side)
    for lo, hi, pose, up in ((max(0, a - blend), a, rot[a, chain], True), (a + k, min(n, a + k + blend), rot[a + k - 1, chain], False)):
        if hi <= lo:
            continue
        u = (np.arange(lo, hi) - lo + 1) / (hi - lo + 1)
        u = _minjerk(u if up else 1.0 - u)
        for c, j in enumerate(chain):
            src = Rotation.from_quat(rot[lo:hi, j])
            dst = Rotation.from_quat(np.repeat(pose[c][None], hi - lo, axis=0))
            rot[lo:hi, j] = (src * Rotation.from_rotvec((src.inv() * dst).as_rotvec() * u[:, None])).as_quat()
    body = walk.replace(rotations=rot, source=SourceInfo(format="synthetic", notes=(
        f"embedded splice ground truth: a {hand_seconds:g} s gesture at body frames {a}-{a + k - 1} of a {body_seconds:g} s walk",)))
    truth = np.full(n, np.nan)
    truth[a:a + k] = sub.truth
    amp = np.ones(n)
    amp[a:a + k] = sub.amplitude
    return SplicePair(body, hand, truth, amp, side, (), f"{sub.description}, embedded at body frames {a}-{a + k - 1} of {n}",
                      dict(sub.params, interval=(a, a + k - 1), n=n, m=m, warp_strength=strength))


def ambiguous_pair(rng=0, *, n_cycles: int = 4, fps: float = 30.0, side: str = "right", noise_deg: float = DEFAULT_NOISE_DEG,
                   amplitude: tuple[float, float] = (0.7, 1.3)) -> SplicePair:
    """The deliberately ambiguous case: the hand recording repeats one gesture
    ``n_cycles`` times back to back (a counting motion, cycles identical up to
    idle drift) and ends with a different gesture; the body recording performs
    only ``n_cycles - 1`` of the cycles before that last gesture, with a mild
    time warp, an amplitude change and a walk underneath.

    Any alignment that skips *one* of the identical hand cycles costs about the
    same, so the data cannot tell which one the body left out. The truth skips
    the last; ``points`` holds two matching points, where the body's last
    performed cycle ends and 0.1 s into the final gesture, which pin the skip
    to the right place.
    """
    rng = np.random.default_rng(rng)
    g = gesture_clip(rng, n_cycles, fps, side, periodic=True, coda=True)
    m = g.motion.n_frames
    cs = g.cycle_starts
    skip_a, skip_b = cs[n_cycles - 1], cs[n_cycles]  # frames of the last identical cycle
    shown = np.concatenate([np.arange(0, skip_a), np.arange(skip_b, m)]).astype(float)
    k = len(shown)
    n = int(round(1.1 * k))
    u = time_warp(n, k, rng, 0.3)  # mild warp of the shown frames
    truth = np.interp(u, np.arange(k), shown)
    jump = skip_a - 1  # index in `shown` of the last frame before the skip
    between = (u > jump) & (u < jump + 1)  # no in-between frames across the cut
    truth = np.where(between, np.where(u - jump < 0.5, shown[jump], shown[jump + 1]), truth)
    walk = walk_clip(n, fps, skeleton=g.motion.skeleton)
    pair = make_splice_pair(g.motion, walk, rng, n_body=n, side=side, warp=truth, amplitude=amplitude, noise_deg=noise_deg)
    x = int(np.nonzero(truth <= skip_a - 1)[0].max())  # last body frame of the last performed cycle
    x2 = int(np.nonzero(truth >= skip_b + 0.1 * fps)[0].min())  # 0.1 s into the final gesture
    pts = ((x, int(round(truth[x])), 0), (x2, int(round(truth[x2])), 0))
    desc = (f"{n_cycles} identical gesture cycles and a final gesture in the hand clip; the body performs "
            f"{n_cycles - 1} cycles (hand frames {skip_a}-{skip_b - 1} skipped); matching points at body frames {x} and {x2}")
    return SplicePair(pair.body, pair.hand, truth, pair.amplitude, side, pts, desc,
                      dict(pair.params, n_cycles=n_cycles, skipped=(int(skip_a), int(skip_b)), cycle_starts=tuple(cs)))


@dataclass(frozen=True, eq=False)
class MarkerPair:
    """A marker-data ground-truth pair (see :func:`make_marker_pair`)."""

    body: object
    hand: object
    truth: np.ndarray
    amplitude: np.ndarray
    side: str
    description: str = ""


_ARM_MARKERS = {"right": ("RWRA", "RWRB", "RFRM", "RFIN", "RELB", "RUPA"), "left": ("LWRA", "LWRB", "LFRM", "LFIN", "LELB", "LUPA")}


def make_marker_pair(markers, rng=0, *, side: str = "right", n_body: int | None = None, warp_strength: float = 0.5,
                     amplitude: tuple[float, float] = (0.5, 1.5), noise: float = 0.002, arm_markers=None) -> MarkerPair:
    """Ground truth for the marker path: ``markers`` (e.g. a Plug-in-Gait C3D)
    is the hand recording; the body recording shows it at the warped frames
    ``truth`` (linear interpolation), with the arm markers' excursion about
    the shoulder (``SHO``) scaled by a smooth factor in ``amplitude`` and
    white noise of ``noise`` metres on every marker."""
    from dataclasses import replace as dc_replace

    from .dtw import warp_values
    from .markers import _lookup

    rng = np.random.default_rng(rng)
    m = markers.n_frames
    n = int(round(1.2 * m)) if n_body is None else int(n_body)
    truth = time_warp(n, m, rng, warp_strength)
    amp = amplitude_profile(n, rng, *amplitude)
    P = warp_values(np.nan_to_num(markers.positions), truth)
    names = arm_markers or _ARM_MARKERS[side]
    sh = _lookup(markers, "RSHO" if side == "right" else "LSHO")
    if sh is None:
        raise AlignmentError(f"no {side} shoulder marker to scale the arm about")
    idx = [k for k in (_lookup(markers, nm) for nm in names) if k is not None]
    rel = P[:, idx] - P[:, sh][:, None]
    mean = rel.mean(axis=0, keepdims=True)
    P[:, idx] = P[:, sh][:, None] + mean + amp[:, None, None] * (rel - mean)
    P = P + rng.normal(scale=noise, size=P.shape)
    mask = warp_values(markers.mask.astype(float), truth) > 0.999
    P[~mask] = np.nan
    body = dc_replace(markers, positions=P, mask=mask, notes=tuple(getattr(markers, "notes", ())) + (
        f"ground truth: warped to {n} frames, arm amplitude {amp.min():.2f}-{amp.max():.2f}, noise {noise} m",))
    return MarkerPair(body, markers, truth, amp, side,
                      f"{m}-frame marker clip warped to {n} frames (strength {warp_strength}), arm amplitude x{amplitude}")
