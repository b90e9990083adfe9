"""BVH parsing speed: ``mocomp.io.read_bvh`` against ``bvhio.readAsBvh`` on the
same 31-joint, 2000-frame file (issue 2: ours at least 10x faster).

The file is the real CMU ``jumps/01_01.bvh`` (cgspeed conversion, 31 joints,
96 channels) truncated to its first 2000 frames, byte for byte, when
``MOCOMP_DATA_DIR`` is set; otherwise a synthetic clip with the same 31-joint
tree, CMU units (1/0.45 inch), channel layout, 4-decimal numbers and the same
still joints (20 all-zero columns), with smooth random rotations, written by our
writer, so that the file has the real one's size and token widths.

Both readers run on the same file in the same process, interleaved (each round:
bvhio once, ours three times) so that both see the same background load and
cache state, with the garbage collector paused. The row reports the **median
CPU time** (``time.process_time``) of the repeats: on 2 cores shared with other
jobs the wall time of a 15 ms call is dominated by preemption; the note gives
wall-time medians and minima too. ``read_bvh`` builds the full
:class:`~mocomp.core.Motion` (unit quaternions, metres, unit check);
``bvhio.readAsBvh`` builds its joint tree with per-frame poses. The note also
gives the largest difference between bvhio's local joint rotations and ours on
every 50th frame (bvhio stores 32-bit floats, so ~1e-7 rad is agreement).

Measured here (1 Dec 2026, 2 shared cores, slower than in Nov: bvhio took 313-569
ms today against ~175 ms then; 5 full runs of ``benchmarks/run.py --only io``
while another helper benchmarked): real file 11.1-17.7 ms (median 11.3) against
bvhio 313-569 ms, ratio 25.5-34.2x (median 28.5x); synthetic file 12.3 ms vs
314-322 ms, 25-26x (2 runs). Before the compiled path the same host gave 59-62 ms
vs 521-537 ms, 8.6-8.8x (Nov: 15.4 vs 175 ms, 11.3x). Where our time goes (profile, warm): the compiled frame-block parse
(:mod:`mocomp.io._bvh_kernels`, exact: ``float(token)`` bits) ~3.5-6 ms where
``numpy.loadtxt`` took ~50 ms; the compiled Euler->quaternion pass ~4-6 ms (half
of it ``sin``/``cos``; the numpy version took ~8 ms); ``Motion`` validation and
copies, the height probe, the header and the file read ~4 ms. Not timed: the first
read in a process also imports numba and loads the cached kernels, ~0.5-0.9 s
once (files under 256 kB of frames skip the kernels, so short clips do not pay it).

A second row times reading an AMC (``jumps/01_01.amc`` with ``01.asf``; no peer
and no goal) when the real data are available.
"""
from __future__ import annotations

import gc
import os
import statistics
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

from mocomp.core import EndSite, Motion, Skeleton, SourceInfo
from mocomp.core.rotations import quat_angle, quat_inverse, quat_multiply
from mocomp.io import UNITS, read_amc, read_bvh, write_bvh

N_FRAMES = 2000
GOAL = "ratio >= 10"
CMU_PARENTS = [-1, 0, 1, 2, 3, 4, 0, 6, 7, 8, 9, 0, 11, 12, 13, 14, 15, 13, 17, 18, 19, 20, 21, 20, 13, 24, 25, 26,
               27, 28, 27]
CMU_NAMES = ["Hips", "LHipJoint", "LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToeBase", "RHipJoint", "RightUpLeg",
             "RightLeg", "RightFoot", "RightToeBase", "LowerBack", "Spine", "Spine1", "Neck", "Neck1", "Head",
             "LeftShoulder", "LeftArm", "LeftForeArm", "LeftHand", "LeftFingerBase", "LFingers", "LThumb",
             "RightShoulder", "RightArm", "RightForeArm", "RightHand", "RightFingerBase", "RFingers", "RThumb"]
# approximate offsets of CMU subject 01 (metres)
CMU_OFFSETS_M = [[0, 0, 0], [0, 0, 0], [.077, -.101, .047], [.138, -.380, 0], [.145, -.397, 0], [.009, -.024, .131],
                 [0, 0, 0], [-.074, -.101, .047], [-.144, -.394, 0], [-.145, -.398, 0], [-.009, -.026, .133],
                 [0, 0, 0], [.003, .116, -.002], [.003, .116, -.002], [0, 0, 0], [-.003, .099, .010],
                 [.002, .100, -.004], [0, 0, 0], [.190, .068, -.018], [.285, 0, 0], [.197, 0, 0], [0, 0, 0],
                 [.040, 0, 0], [0, 0, 0], [0, 0, 0], [-.190, .068, -.018], [-.285, 0, 0], [-.197, 0, 0], [0, 0, 0],
                 [-.040, 0, 0], [0, 0, 0]]


def _data_dir() -> Path | None:
    d = os.environ.get("MOCOMP_DATA_DIR")
    return Path(d) if d and Path(d).is_dir() else None


def make_file(folder: Path, n_frames: int = N_FRAMES) -> tuple[Path, float, str]:
    """Write the benchmark BVH into ``folder``; returns (path, scale for read_bvh, description)."""
    d = _data_dir()
    src = d / "jumps" / "01_01.bvh" if d else None
    out = folder / f"bench_{n_frames}.bvh"
    if src is not None and src.is_file():
        lines = src.read_bytes().split(b"\n")
        k = next(i for i, ln in enumerate(lines) if ln.lstrip().startswith(b"Frames:"))
        head = lines[:k] + [b"Frames: %d\r" % n_frames] + [lines[k + 1]]
        out.write_bytes(b"\n".join(head + lines[k + 2:k + 2 + n_frames]) + b"\n")
        return out, "cmu", f"real CMU jumps/01_01.bvh, first {n_frames} frames (31 joints, 96 channels)"
    rng = np.random.default_rng(7)
    J = len(CMU_PARENTS)
    t = np.arange(n_frames) / 120.0
    freq = rng.uniform(0.3, 2.0, (J, 3))
    phase = rng.uniform(0, 2 * np.pi, (J, 3))
    ang = 0.6 * np.sin(2 * np.pi * freq[None] * t[:, None, None] + phase[None])  # radians
    ang[:, 0, 1] = 0.8 * t  # the root turns about the vertical
    # joints that do not move in the CMU files (ASF bones without dofs): 20 of the 96 columns are 0
    ang[:, [1, 6, 17, 24]] = 0.0
    ang[:, [20, 27], 1:] = 0.0  # hands: one axis
    ang[:, [22, 29], :2] = 0.0  # fingers: one axis
    from scipy.spatial.transform import Rotation

    rots = Rotation.from_rotvec(ang.reshape(-1, 3)).as_quat().reshape(n_frames, J, 4)
    root = np.stack([0.5 * np.sin(t), 0.95 + 0.05 * np.sin(3 * t), 0.3 * t], axis=1)
    ends = (EndSite(5, [0, 0, 0.067], "LeftToe_end"), EndSite(10, [0, 0, 0.068], "RightToe_end"),
            EndSite(16, [0, 0.1, 0], "Head_end"), EndSite(22, [0.033, 0, 0], "LFingers_end"),
            EndSite(23, [0.033, 0, 0.033], "LThumb_end"), EndSite(29, [-0.033, 0, 0], "RFingers_end"),
            EndSite(30, [-0.033, 0, 0.033], "RThumb_end"))
    chans = [("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation")] + \
        [("Zrotation", "Yrotation", "Xrotation")] * (J - 1)
    sk = Skeleton(tuple(CMU_NAMES), np.array(CMU_PARENTS), np.array(CMU_OFFSETS_M), tuple(chans), ends)
    m = Motion(sk, 120.0, root, rots, source=SourceInfo(format="synthetic"))
    write_bvh(m, out, scale=UNITS["cmu"], precision=4)  # CMU units and 4 decimals, like the real file
    return out, "cmu", (f"synthetic 31-joint clip in the CMU tree, units and number format, {n_frames} frames "
                        "(MOCOMP_DATA_DIR not set)")


def _timed(fn) -> tuple[float, float, object]:
    """(CPU seconds of this process, wall seconds, output) of one call, GC paused."""
    gc_was = gc.isenabled()
    gc.disable()
    try:
        c0, t0 = time.process_time(), time.perf_counter()
        out = fn()
        return time.process_time() - c0, time.perf_counter() - t0, out
    finally:
        if gc_was:
            gc.enable()


def _time(fn, repeat: int) -> tuple[float, float, object]:
    """(median, min) CPU time of ``fn()`` over ``repeat`` runs and the last output."""
    ts, out = [], None
    for _ in range(repeat):
        dt, _, out = _timed(fn)
        ts.append(dt)
    return statistics.median(ts), min(ts), out


def _time_pair(ours, peer, rounds: int, per_round: int) -> dict:
    """Interleaved timing on a shared machine: each round runs the peer once and
    ours ``per_round`` times, so both see the same background load and cache
    state. Medians and minima of CPU and wall time for both, and the outputs."""
    r: dict = {"ours_cpu": [], "ours_wall": [], "peer_cpu": [], "peer_wall": []}
    for _ in range(rounds):
        c, w, r["peer_out"] = _timed(peer)
        r["peer_cpu"].append(c)
        r["peer_wall"].append(w)
        for _ in range(per_round):
            c, w, r["ours_out"] = _timed(ours)
            r["ours_cpu"].append(c)
            r["ours_wall"].append(w)
    for k in ("ours_cpu", "ours_wall", "peer_cpu", "peer_wall"):
        r[k + "_min"] = min(r[k])
        r[k] = statistics.median(r[k])
    return r


def _agreement(motion: Motion, bvh) -> float:
    """Largest angle (rad) between bvhio's local rotations and ours, every 50th frame."""
    layout = bvh.Root.layout()
    frames = np.arange(0, motion.n_frames, 50)
    worst = 0.0
    for joint, _, _ in layout:
        j = motion.skeleton.find(joint.Name)
        if j is None:
            continue
        q = np.array([[k.Rotation.x, k.Rotation.y, k.Rotation.z, k.Rotation.w]
                      for k in (joint.Keyframes[i] for i in frames)])
        d = quat_angle(quat_multiply(quat_inverse(q / np.linalg.norm(q, axis=1, keepdims=True)),
                                     motion.rotations[frames, j]))
        worst = max(worst, float(d.max()))
    return worst


def run(quick: bool) -> list[dict]:
    import bvhio

    rows = []
    reps_ours, reps_peer = (9, 3) if quick else (21, 7)
    with tempfile.TemporaryDirectory() as tmp, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        path, scale, desc = make_file(Path(tmp))
        read_bvh(path, scale=scale)  # warm caches (imports, file cache) for both
        bvhio.readAsBvh(str(path))
        t = _time_pair(lambda: read_bvh(path, scale=scale), lambda: bvhio.readAsBvh(str(path)),
                       reps_peer, reps_ours // reps_peer)
        agree = _agreement(t["ours_out"], t["peer_out"])
        rows.append({
            "name": f"BVH read 31j x {N_FRAMES}f", "ours_s": t["ours_cpu"], "peer": "bvhio.readAsBvh",
            "peer_s": t["peer_cpu"], "ratio": t["peer_cpu"] / t["ours_cpu"], "goal": GOAL,
            "note": (f"{desc}; CPU-time medians of {reps_ours}/{reps_peer} interleaved runs; wall-time medians "
                     f"{t['ours_wall'] * 1e3:.1f} ms vs {t['peer_wall'] * 1e3:.0f} ms "
                     f"({t['peer_wall'] / t['ours_wall']:.1f}x), wall minima {t['ours_wall_min'] * 1e3:.1f} vs "
                     f"{t['peer_wall_min'] * 1e3:.0f} ms; max local-rotation difference to bvhio {agree:.1e} rad"),
        })
        d = _data_dir()
        if d is not None and (d / "jumps" / "01_01.amc").is_file():
            amc = d / "jumps" / "01_01.amc"
            med, mn, m = _time(lambda: read_amc(amc), 3 if quick else 7)
            rows.append({
                "name": f"AMC read 31j x {m.n_frames}f", "ours_s": med, "peer": None, "peer_s": None,
                "ratio": None, "goal": None,
                "note": f"real CMU jumps/01_01.amc with 01.asf, CPU-time median (min {mn * 1e3:.0f} ms); no peer",
            })
    return rows


if __name__ == "__main__":
    for r in run(quick=True):
        print(r)
