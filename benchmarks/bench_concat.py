"""Angular-momentum-guided concatenation (issue 17, Shum et al. 2009).

Goals (issue 17): the timing search for two 3-second clips at 120 fps **under 5 ms**; a whole
two-motion concatenation **under 50 ms** (the paper: "tens of seconds", brute force on a Core Duo).

Rows (best of N wall time, garbage collector paused):

* ``timing``: :func:`mocomp.concat.timing_table` (eq. 3-7 for every offset T, the (T, f) band at
  once) on two 360-frame trajectories with the whole clips as blendable periods (the worst case:
  719 offsets). Input: the eq. 1 track of the embedded synthetic backflip (323 frames at 120 fps)
  padded to 360 frames. Peer: the paper's brute force, a Python loop over T with the inner scan over
  f in numpy (same table; the test suite checks the two agree).
* ``concatenate``: :func:`mocomp.concat.concatenate` of the synthetic backflip with itself, end to
  end: two eq. 1 tracks, phases, rule, eq. 2, foot-plant detection of both, timing, eq. 8, eq. 9
  (one more eq. 1 track), without and with the feet held (ops.enforce_footplants).

Measured (2026-12-02, 2 cores shared with three other jobs; best of 10-30): timing search 3.0-4.4 ms
(goal met; brute force 30-47 ms); concatenate without the feet held 44-56 ms, with them 49-98 ms (the
goal is met or missed by up to ~2x with the load). Where the time goes without the feet held: two eq. 1 tracks (~11 ms each: FK of the pre-smoothed motion,
angular velocities), the foot-plant detection of both inputs (~11 ms each, for the double-support
truncation and the plants), eq. 9's track of the window (~3 ms), the rest (alignment, timing, blend)
a few ms.

Re-measured 2026-12-02 16:00 after the one-kernel merge (issue 14), at load 4: timing search 1.5 ms,
concatenate 9.7 ms without the feet held, 15.6 ms with them (stop 23 noted 113 ms at load 10). Then, in
mocomp.concat, A/B alternated in one process at load 8-9 (min of 12-15): the body model kept between
calls (``phases.body_of``: a DeepMimic clip's character file was parsed on every call, ~7 ms) -- DeepMimic
side flip x2 24.8 -> 11.3 ms, spin kick + kick 21.4 -> 11.0, SIE punches 25.5 -> 20.3; a motion chained
with itself gets one eq. 1 track and one plant detection -- synthetic back flip x2 43.3 -> 29.8 ms.
Where the time goes now (synthetic back flip, two copies): the footplant enforcement ~40 % (its contact
re-detection and IK), three contact detections, three eq. 1 tracks, the rest a few ms.

Issue 17's later steps (window search, plants held where both motions plant, vertical COM continuity)
took "feet held" 19.2 -> 26.8 ms. A/B in one process (code before those steps, f7550cd, this version;
alternated, min of 12, 2026-12-02 18:57 UTC, load 1.6-2.4): same motion 22.9 -> 15.5 ms, two copies
27.2 -> 17.9 ms, no feet held 8.0 -> 6.7 ms (the code before issue 17's later steps: 10.5 / 13.7 /
5.9). Same outputs bit for bit except where the second footplant enforcement is no longer tried
(below): (1) the window search's blend and eq. 9 re-timing are kept and reused for the chosen window
(was blended twice); (2) eq. 9's re-timing maps both plant labellings at once (was a second re-timing
for the labels alone); (3) |L| between the main phases on that range only; (4) the plants held only
where both motions plant (a second enforce_footplants, ~8 ms) are tried only when A's / B's plants
leave |L| below 30 % of the main level (SFU Wushu kicks 0.96 -> 0.91, cartwheels 1.05 -> 0.86: both
well above). What the remaining ~4 ms over the code before those steps is: the grounding check
(the audit's contact detection on the result, ~2.3 ms), the window search's and the plant choice's
eq. 1 tracks on the range (~1 ms each).

The grounding (feet <= 1 cm slide, no floor penetration, ``concatenate(ground=True)``) costs nothing
more here (the synthetic flips do not sink: the check alone), but on the real pairs that sink it does
(2026-12-02 19:06 UTC, load ~2, min of 5, with / without): DeepMimic back flip x2 52.7 / 17.8 ms,
CMU 88_01 x2 66.4 / 21.2, CMU 90_08 x2 32.3 / 20.6, SFU cartwheels 35.6 / 19.8, SIE punches 88.2 / 61.9
(two runs: the longer windows). Most of it is ops.enforce_footplants' own extra passes (their contact
detections and floor checks), run twice where the lift is needed before the feet are held too
(DeepMimic side and back flips, CMU 88_01).
"""
from __future__ import annotations

import numpy as np

from timing import best_of, result


def _brute(t1, t2, p1, p2):
    out = []
    for T in range(p1[0] - (p2[1] - 1), p1[1] - p2[0]):
        f = np.arange(max(p1[0], p2[0] + T), min(p1[1], p2[1] + T))
        d = ((t1.L[f] - t2.L[f - T]) ** 2).sum(1)
        k = int(np.argmin(d))
        fT = int(f[k])
        r1, r2 = t1.arms[fT], t2.arms[fT - T]
        Fi = float(t1.masses @ (np.einsum("sc,sc->s", r1, r2 - r1) ** 2))
        out.append((T, fT, d[k] + Fi + float(((t1.L[fT] - t1.L[p1[0]]) ** 2).sum())))
    return out


def run(quick: bool) -> list[dict]:
    import warnings

    from mocomp import datasets
    from mocomp.concat import MomentumTrack, concatenate, momentum_track, timing_table

    m = datasets.load("backflip")
    tr = momentum_track(m)
    n = 360
    pad = n - tr.n_frames
    t = MomentumTrack(np.concatenate([tr.L, tr.L[-1:].repeat(pad, 0)]),
                      np.concatenate([tr.arms, tr.arms[-1:].repeat(pad, 0)]), tr.masses, tr.fps)
    repeat = 5 if quick else 30
    p = (0, n)
    timing_table(t, t, p, p)
    t_ours, tab = best_of(lambda _: timing_table(t, t, p, p), repeat, lambda: None)
    t_peer, _ = best_of(lambda _: _brute(t, t, p, p), max(2, repeat // 10), lambda: None)
    rows = [result(f"timing search, 2 x {n} frames (3 s at 120 fps), {len(tab.T)} offsets", t_ours,
                   "the paper's brute force (loop over T, numpy over f)", t_peer, goal="ours_s <= 0.005",
                   note="synthetic backflip eq. 1 track padded to 360 frames; whole clips as blendable periods")]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        concatenate(m, m, plant=False)
        t_c, r = best_of(lambda mm: concatenate(mm, mm, plant=False), max(3, repeat // 3), lambda: m.replace())
        t_cp, _ = best_of(lambda mm: concatenate(mm, mm), max(2, repeat // 6), lambda: m.replace())
        t_c2, _ = best_of(lambda ab: concatenate(*ab), max(2, repeat // 6), lambda: (m.replace(), m.replace()))
    rows.append(result(f"concatenate 2 x {m.n_frames}f backflips (no feet held)", t_c, goal="ours_s <= 0.05",
                       note=f"synthetic backflip; T={r.T}, window {r.window}, s={r.scale:.2f}"))
    rows.append(result("concatenate, feet held (ops.enforce_footplants)", t_cp, goal="ours_s <= 0.05",
                       note="synthetic backflip chained with itself (one eq. 1 track, one plant detection)"))
    rows.append(result("concatenate, feet held, A and B two copies", t_c2, goal="ours_s <= 0.05",
                       note="as above with B a separate Motion: both tracks and both plant detections computed"))
    return rows
