"""Forward kinematics of a 31-joint, 10,000-frame clip: ``Motion.positions`` on a
fresh motion (empty FK cache) against two peers on the same clip.

* ``bvhio`` (PyPI ``bvhio``): ``root.loadPose(frame)`` then ``joint.PositionWorld``
  for every joint, frame by frame (its documented way to get world positions).
  Its BVH parse is not timed here (see the BVH benchmark).
* ``scipy Rotation``: what a careful researcher writes by hand: a loop over
  joints, each step vectorised over frames with ``Rotation`` products and
  ``Rotation.apply``.

The clip is the real CMU ``jumps/01_01.bvh`` (31 joints) repeated to 10,000
frames when ``MOCOMP_DATA_DIR`` is set, else a synthetic 31-joint clip with the
same tree and smooth random joint rotations. Goal (issue 2): at most 50 ms.

Ours is :func:`mocomp.core.kinematics.forward_kinematics`: compiled
(:mod:`mocomp.core._compiled`) once numba is loaded in the process (reading the real clip
loads it), else the numpy reference; the note says which ran. A third row times the numpy
reference alone (the backend with ``MOCOMP_NO_NUMBA=1``), which gives the same bits.

Two more rows time core's joint velocities on the same clip: the world angular velocity of every
joint frame (:func:`mocomp.core.kinematics.angular_velocity` of the FK orientations, order 2:
compiled once numba is loaded, and its numpy reference) against the scipy way (``Rotation``
products and ``as_rotvec`` of the relative rotation between frames, the same central blend: what
``mocomp.dynamics`` ran before the velocities moved to core). No goal.
"""
from __future__ import annotations

import os
import tempfile
import warnings
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from mocomp.core import Motion, Skeleton, SourceInfo, concatenate
from mocomp.io import read_bvh, write_bvh
from timing import best_of, result

N_FRAMES = 10_000
GOAL_S = 0.050
# the CMU (cgspeed MotionBuilder-friendly) 31-joint tree
CMU_PARENTS = [-1, 0, 1, 2, 3, 4, 0, 6, 7, 8, 9, 0, 11, 12, 13, 14, 15, 13, 17, 18, 19, 20, 21, 20, 13, 24, 25, 26,
               27, 28, 27]


def clip(n_frames: int = N_FRAMES) -> tuple[Motion, str]:
    """The benchmark clip and a description of where it came from."""
    d = os.environ.get("MOCOMP_DATA_DIR")
    f = Path(d) / "jumps" / "01_01.bvh" if d else None
    if f is not None and f.is_file():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            m = read_bvh(f, scale="cmu")
        reps = -(-n_frames // m.n_frames)
        return concatenate([m] * reps)[:n_frames], f"real CMU 01_01 (31 joints) tiled to {n_frames} frames"
    rng = np.random.default_rng(2)
    J = len(CMU_PARENTS)
    names = [f"joint{j}" for j in range(J)]
    offsets = rng.normal(size=(J, 3)) * 0.12
    offsets[0] = 0.0  # bvhio ignores a root OFFSET when the root has position channels; we add it (as CMU files are 0)
    sk = Skeleton(names, CMU_PARENTS, offsets)
    t = np.arange(n_frames) / 120.0
    freq = rng.uniform(0.2, 2.0, size=(J, 3))
    amp = rng.uniform(0.2, 1.2, size=(J, 3))
    rv = amp[None] * np.sin(2 * np.pi * freq[None] * t[:, None, None])
    rot = Rotation.from_rotvec(rv.reshape(-1, 3)).as_quat().reshape(n_frames, J, 4)
    root = np.column_stack([np.sin(t), 0.9 + 0.05 * np.cos(3 * t), 0.3 * t])
    return Motion(sk, 120.0, root, rot, source=SourceInfo(format="synthetic")), \
        f"synthetic 31-joint clip, {n_frames} frames (set MOCOMP_DATA_DIR for the real CMU 01_01)"


def scipy_fk(m: Motion) -> np.ndarray:
    """Per-joint loop, vectorised over frames with scipy Rotation."""
    sk = m.skeleton
    glob = [Rotation.from_quat(m.rotations[:, 0])]
    pos = [np.array(m.root_positions)]
    for j in range(1, sk.n_joints):
        p = int(sk.parents[j])
        glob.append(glob[p] * Rotation.from_quat(m.rotations[:, j]))
        pos.append(pos[p] + glob[p].apply(np.array(sk.offsets[j])))
    return np.stack(pos, axis=1)


def bvhio_fk(root, joints, n_frames: int) -> np.ndarray:
    out = np.empty((n_frames, len(joints), 3))
    for f in range(n_frames):
        root.loadPose(f)
        for k, j in enumerate(joints):
            p = j.PositionWorld
            out[f, k] = (p.x, p.y, p.z)
    return out


def run(quick: bool) -> list[dict]:
    import bvhio

    m, origin = clip(N_FRAMES)
    repeat = 5 if quick else 15
    ours_s, P = best_of(lambda mm: mm.positions, repeat=repeat, setup=lambda: m.replace())
    import sys

    from mocomp.core import _compiled

    backend = ("compiled (numba, mocomp.core._compiled)" if _compiled.AVAILABLE and "numba" in sys.modules
               else "the numpy reference")
    rows = []

    # bvhio: per-frame; quick mode times 500 frames and scales linearly to 10,000
    n_peer = 500 if quick else N_FRAMES
    with tempfile.TemporaryDirectory() as tmp:
        path = write_bvh(m[:n_peer], Path(tmp) / "fk_clip.bvh", precision=10)
        root = bvhio.readAsHierarchy(str(path))
    joints = {j.Name: j for j, _, _ in root.layout()}
    order = [joints[n] for n in m.skeleton.names]
    peer_s, Pb = best_of(lambda _: bvhio_fk(root, order, n_peer), repeat=1 if not quick else 2)
    scale_note = "" if n_peer == N_FRAMES else f"; bvhio timed on {n_peer} frames x {N_FRAMES // n_peer} (per-frame cost)"
    peer_s *= N_FRAMES / n_peer
    err = float(np.abs(Pb - P[:n_peer]).max())
    rows.append(result(
        f"fk {m.skeleton.n_joints}j x {m.n_frames}f", ours_s, f"bvhio {bvhio_version()} loadPose+PositionWorld", peer_s,
        goal=f"ours_s <= {GOAL_S}",
        note=f"{origin}; max |ours - bvhio| = {err:.1e} m{scale_note}"))

    sc_s, Ps = best_of(lambda mm: scipy_fk(mm), repeat=3 if quick else 7, setup=lambda: m)
    err = float(np.abs(Ps - P).max())
    rows.append(result(
        f"fk {m.skeleton.n_joints}j x {m.n_frames}f", ours_s, "scipy Rotation per joint (vectorised)", sc_s,
        note=f"same clip; max |ours - scipy| = {err:.1e} m; ours ran {backend}"))

    # the numpy reference alone (what runs without numba, MOCOMP_NO_NUMBA=1): no goal
    from mocomp.core.kinematics import forward_kinematics_numpy

    sk = m.skeleton
    np_s, Pn = best_of(lambda mm: forward_kinematics_numpy(sk.parents, sk.offsets, mm.root_positions, mm.rotations)[0],
                       repeat=3 if quick else 7, setup=lambda: m)
    rows.append(result(
        f"fk {sk.n_joints}j x {m.n_frames}f, numpy reference", np_s, "scipy Rotation per joint (vectorised)", sc_s,
        note=f"mocomp.core.kinematics.forward_kinematics_numpy (the backend without numba); "
             f"identical to the compiled result: {bool(np.array_equal(Pn, P))}"))
    rows += velocity_rows(m, quick)
    return rows


def scipy_angular_velocity(G: np.ndarray, t: np.ndarray) -> np.ndarray:
    """World angular velocities the scipy way: ``as_rotvec`` of ``q_{i+1} q_i^-1`` over the step,
    blended with the central-difference weights (uniform steps here: the mean of the two)."""
    T, J = G.shape[:2]
    r = Rotation.from_quat(G.reshape(-1, 4))
    q = r.as_quat().reshape(T, J, 4)
    a = Rotation.from_quat(q[1:].reshape(-1, 4))
    b = Rotation.from_quat(q[:-1].reshape(-1, 4))
    step = (a * b.inv()).as_rotvec().reshape(T - 1, J, 3) / np.diff(t)[:, None, None]
    out = np.empty((T, J, 3))
    out[0], out[-1] = step[0], step[-1]
    out[1:-1] = 0.5 * (step[1:] + step[:-1])
    return out


def velocity_rows(m: Motion, quick: bool) -> list[dict]:
    from mocomp.core.kinematics import angular_velocity, angular_velocity_numpy

    _, G = m.fk()
    t = m.times
    repeat = 3 if quick else 7
    ours_s, w = best_of(lambda _: angular_velocity(G, t), repeat=repeat)
    np_s, wn = best_of(lambda _: angular_velocity_numpy(G, t), repeat=repeat)
    sc_s, ws = best_of(lambda _: scipy_angular_velocity(G, t), repeat=repeat)
    d = float(np.abs(w - ws).max())
    dn = float(np.abs(w - wn).max())
    name = f"angular velocity {G.shape[1]}j x {G.shape[0]}f (world, every joint frame)"
    return [
        result(name, ours_s, "scipy Rotation products + as_rotvec", sc_s,
               note=f"mocomp.core.kinematics.angular_velocity (order 2) of the FK orientations; max |ours - scipy| "
                    f"= {d:.1e} rad/s (rates up to {float(np.abs(ws).max()):.0f} rad/s)"),
        result(name + ", numpy reference", np_s, "scipy Rotation products + as_rotvec", sc_s,
               note=f"mocomp.core.kinematics.angular_velocity_numpy (the backend without numba); max |numpy - "
                    f"compiled| = {dn:.1e} rad/s"),
    ]


def bvhio_version() -> str:
    from importlib.metadata import version

    return version("bvhio")
