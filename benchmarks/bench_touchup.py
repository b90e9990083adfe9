"""Physical touch-up (issue 16): the paper's four edited motions (:mod:`mocomp.touchup.examples`)
cut to the paper's frame counts, each with the paper's schedule (walk -> jog and the curved jump:
``default`` = ``ground-default`` 5 + 5 + 2 iterations then ``flight-default``; curved walk
``ground-default``; uphill ``uphill``), footplants re-enforced after every step that moves the feet,
beside the paper's timings on the same frame counts.

Goals (issue 16): a 100-frame clip **under 10 ms** (the runner's best-of; the issue asks for the
median), and 10,000 frames **under 1 s** (linear growth).

Input: with ``MOCOMP_DATA_DIR``, the real clips of :func:`mocomp.touchup.examples.paper_examples`
(Bandai-Namco-2 walk and run, the captured turn's path, a 10 deg slope, the CMU 01_01 hop on an
arc); without it the synthetic walk (path-edited, uphill) only. The 10,000-frame row is the
synthetic walk at 120 Hz with ``ground-default`` (full run only).

Peer: the paper's own numbers (Shin, Kovar & Gleicher 2003, sec. 4: 0.108, 0.172, 0.211, 0.14 s
on a 2.0 GHz Xeon), quoted, not rerun. The note gives the best CPU time of the process beside the
runner's wall time: on the shared 2-core machine (load 8-10) the wall time is 3-5 times the CPU time.

Measured (2026-12-02, load 8-10 on 2 cores, after the paper's 5 + 5 + 2 iterations were restored,
so 12 ground iterations instead of 3), CPU best of 5 beside the paper: walk -> jog 98 frames
0.13-0.17 s vs 0.108; curved walk 111 frames 0.128 s vs 0.172; uphill 166 frames 0.147 s vs 0.211;
curved hop 91 frames at 120 Hz 0.196 s vs 0.14 (wall time 3-5x the CPU time at that load). Cut to
98 frames the walk -> jog example ends before its blend window (frames 110-130): those 98 frames
are walk only. The 10 ms goal is missed by more than 10x: every iteration runs forward kinematics
twice (the motion and its smoothed copy for eq. 4), the eq. 6-7 solve and the map, and the steps
that move the feet (the lower body in S2) a contact-free leg IK (:func:`mocomp.ops.enforce_footplants`,
against the input's own correction computed once) and the legs' lift with their forward kinematics.
The 10,000-frame row was not rerun after the iterations went from 3 to 12 (12.6 s before).
"""
from __future__ import annotations

import time

from timing import best_of, result


def run(quick: bool = False) -> list[dict]:
    from mocomp.audit import default_body
    from mocomp.touchup import touchup
    from mocomp.touchup.examples import PAPER_TIMINGS, paper_examples

    rows = []
    for name, e in paper_examples().items():
        n, paper_s = PAPER_TIMINGS[name]
        m = e.motion.slice(0, min(n, e.motion.n_frames))
        body = default_body(m)
        cpu = []

        def go(_):
            t0 = time.process_time()
            out = touchup(m, body, e.schedule)
            cpu.append(time.process_time() - t0)
            return out

        s, r = best_of(go, repeat=2 if quick else 5)
        rows.append(result(f"touchup {e.schedule}, {m.n_frames} frames ({name})", s,
                           "paper (Shin et al. 2003, 2.0 GHz Xeon)", paper_s,
                           "ours_s <= 0.01" if m.n_frames <= 100 else None,
                           f"{e.source}; CPU best {min(cpu):.3f} s; planned mean ZMP outside "
                           f"{r.before['mean_outside_m'] * 100:.1f} -> {r.after['mean_outside_m'] * 100:.1f} cm"))
    if not quick:
        from mocomp.ops.synthetic import synthetic_walk

        m = synthetic_walk(duration=10000 / 120.0 - 1e-9, fps=120.0).motion
        body = default_body(m)
        s, _ = best_of(lambda _: touchup(m, body, "ground-default"), repeat=1)
        rows.append(result(f"touchup ground-default, {m.n_frames} frames", s, goal="ours_s <= 1.0",
                           note="synthetic walk at 120 Hz"))
    return rows
