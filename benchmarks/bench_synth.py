"""Generation time of the embedded synthetic examples, with their conservation figures.

Ours: each :mod:`mocomp.synth` generator with the example's parameters, from
scratch (no cache): key poses, shooting on L0 (RK4 at 960 Hz), ground phases.
No peer library generates such motions, so the rows have no ratio; the goal
(issue 3 brief) is a generation time "well under a second or two": 1 s per
example at 120 fps, 2 s for the 960 fps backflip.

The note of each row reports what the project's own dynamics measures on the
result (issue 3's conservation figure): the max relative deviation
``|L - L0| / |L0|`` over the flight from the generator's exact rates
(``momentum(body, motion, velocity=r.velocities)``, no time differences: ~1e-14
at every rate) and, for comparison, with central differences
(:func:`mocomp.dynamics.momentum` default; O(dt^2): 3.1e-3 .. 5.5e-2 at 120 fps,
< 1e-4 for the backflip at 960 fps), and the COM's distance from the exact
parabola (:func:`mocomp.dynamics.center_of_mass`).
"""
from __future__ import annotations

import numpy as np

from mocomp.dynamics import center_of_mass, momentum
from mocomp.synth import backflip, frontflip, sideflip, straight_jump, twist_jump
from timing import best_of, result

CASES = {
    "backflip": lambda fps: backflip(fps=fps),
    "frontflip": lambda fps: frontflip(fps=fps),
    "sideflip": lambda fps: sideflip(fps=fps),
    "twist180": lambda fps: twist_jump(twist=180.0, fps=fps),
    "twist360": lambda fps: twist_jump(twist=360.0, fps=fps),
    "jump": lambda fps: straight_jump(fps=fps),
}


def figures(r) -> str:
    m = r.motion
    a, b = r.flight
    t0, t1 = r.flight_times
    idx = np.arange(a, b)
    idx = idx[(m.times[idx] - m.dt >= t0 - 1e-12) & (m.times[idx] + m.dt <= t1 + 1e-12)]
    L0n = np.linalg.norm(r.L0)
    L = momentum(r.body, m).angular[idx]
    dev = np.linalg.norm(L - r.L0, axis=1).max() / L0n
    exact = np.linalg.norm(r.exact_momentum().angular[a:b] - r.L0, axis=1).max() / L0n
    com = np.abs(center_of_mass(r.body, m)[a:b] - r.com_target()).max()
    return (f"{m.n_frames} frames at {m.fps:g} fps; |L0| {L0n:.2f} kg m^2/s; "
            f"flight |L-L0|/|L0| {exact:.0e} (exact rates), {dev:.1e} (central differences); "
            f"COM-parabola residual {com:.0e} m; "
            f"{r.evidence.shooting_evaluations} shooting integrations")


def run(quick: bool) -> list[dict]:
    rows = []
    repeat = 1 if quick else 3
    for name, make in CASES.items():
        s, r = best_of(lambda _: make(120.0), repeat=repeat)
        rows.append(result(f"synth {name} 120 fps", s, goal="ours_s <= 1.0", note=figures(r)))
    s, r = best_of(lambda _: backflip(fps=960.0), repeat=1)
    rows.append(result("synth backflip 960 fps", s, goal="ours_s <= 2.0", note=figures(r)))
    return rows
