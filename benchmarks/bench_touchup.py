"""Physical touch-up (issue 16): the full default schedule (``ground-default`` then
``flight-default``, one iteration per step, footplants re-enforced after each) beside the paper's
timings on the same frame counts.

Goals (issue 16): a 100-frame clip **under 10 ms** (the runner's best-of; the issue asks for the
median), and 10,000 frames **under 1 s** (linear growth).

Input: with ``MOCOMP_DATA_DIR``, the real Bandai-Namco-2 straight walk (30 Hz, 22 joints) cut to
the paper's walk frame counts (98: walk -> jog, 111: curved walk, 166: uphill) rotated onto a
10 deg slope (:func:`mocomp.ops.slope`: a clip that needs the touch-up), and the SFU two-feet jump
(120 Hz) cut to 91 frames around its first flight (the curved jump's count); without it the
synthetic walk (:mod:`mocomp.ops.synthetic`, 30 Hz) of the same lengths. The 10,000-frame row
repeats the synthetic walk at 120 Hz (full run only).

Peer: the paper's own numbers (Shin, Kovar & Gleicher 2003, sec. 4: 0.108, 0.172, 0.211, 0.14 s
on a 2.0 GHz Xeon), quoted, not rerun.

Measured (2026-12-02, 2 cores shared with three other jobs, real clips, ``--quick`` best of 2):
98 frames 243 ms, 111 frames 240 ms, 166 frames 300 ms, 91 jump frames 244 ms (the paper: 108,
172, 211, 140 ms in 2003); the synthetic 10,001-frame walk with ``ground-default`` took 12.6 s.
Both goals are missed, the 100-frame one by ~25x. Where the time goes: the footplant enforcement
runs twice per step (on the step's result and on the motion before it, so that the plants are held
against what the step moved), each with contact-free IK and FK; every iteration also re-runs FK,
the ZMP's smoothing and polygon distances, and the measurements recorded per iteration
(:func:`mocomp.touchup.iterate.touchup`'s history: ZMP, COM, momentum).
"""
from __future__ import annotations

from timing import best_of, result

PAPER = ((98, 0.108, "walk -> jog"), (111, 0.172, "curved walk"), (166, 0.211, "uphill walk"),
         (91, 0.14, "curved jump"))


def _clips():
    from mocomp.datasets import data_dir, load
    from mocomp.ops import slope
    from mocomp.ops.synthetic import synthetic_walk

    d = data_dir()
    out = []
    for n, t, what in PAPER:
        if d is not None:
            if what == "curved jump":
                m = load(d / "jumps" / "sfu_0005_2FeetJump001.bvh").slice(70, 70 + n)
                src = "SFU 2FeetJump frames 70-160 (120 Hz, one flight)"
            else:
                m = slope(load(d / "walks" / "bandai2_walk_normal_001.bvh").slice(0, n), 10.0).motion
                src = f"Bandai-2 walk frames 0-{n - 1} on a 10 deg slope"
        else:
            m = synthetic_walk(duration=(n - 1) / 30.0, fps=30.0).motion
            src = f"synthetic walk, {n} frames at 30 Hz"
        out.append((n, t, what, m, src))
    return out


def run(quick: bool = False) -> list[dict]:
    from mocomp.audit import default_body
    from mocomp.touchup import touchup

    rows = []
    for n, t, what, m, src in _clips():
        body = default_body(m)
        s, r = best_of(lambda _: touchup(m, body), repeat=2 if quick else 5)
        rows.append(result(f"touchup default schedule, {n} frames ({what})", s,
                           "paper (Shin et al. 2003, 2.0 GHz Xeon)", t,
                           "ours_s <= 0.01" if n <= 100 else None,
                           f"{src}; mean ZMP outside {r.before['mean_outside_m'] * 100:.1f} -> "
                           f"{r.after['mean_outside_m'] * 100:.1f} cm"))
    if not quick:
        from mocomp.ops.synthetic import synthetic_walk

        m = synthetic_walk(duration=10000 / 120.0 - 1e-9, fps=120.0).motion
        body = default_body(m)
        s, _ = best_of(lambda _: touchup(m, body, "ground-default"), repeat=1)
        rows.append(result(f"touchup ground-default, {m.n_frames} frames", s, goal="ours_s <= 1.0",
                           note="synthetic walk at 120 Hz"))
    return rows
