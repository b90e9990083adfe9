"""The touch-up paper's edited inputs (Shin et al. 2003, sec. 4.2-4.5), made from real clips with
the project's editing primitives (:mod:`mocomp.ops`), or from the synthetic walk without the data
directory. Used by ``notebooks/touchup.ipynb`` and ``benchmarks/bench_touchup.py``.

* ``walk-jog`` (sec. 4.2, Fig. 6): the Bandai-Namco-2 walk blended into its run over 20 frames
  (:func:`mocomp.ops.blend`); paper: 98 frames, 0.108 s;
* ``curved-walk`` (sec. 4.3, Fig. 7-9): the straight Bandai walk path-edited onto the path of the
  captured left-turning walk (:func:`mocomp.ops.path_edit`), the capture kept as the reference;
  paper: 111 frames, 0.172 s;
* ``uphill`` (sec. 4.4, Fig. 10): the walk rotated onto a 10 deg slope (:func:`mocomp.ops.slope`),
  the ``uphill`` schedule; paper: 166 frames, 0.211 s;
* ``curved-jump`` (sec. 4.5, Fig. 11): a CMU 01_01 forward hop (frames 400-499, one flight; the
  SFU two-feet jump stays in place: no path to bend) path-edited onto a 60 deg arc of its own
  length; paper: 91 frames, 0.14 s.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["Example", "paper_examples", "PAPER_TIMINGS"]

#: the paper's frame counts and seconds (sec. 4.2-4.5, a 2.0 GHz Xeon)
PAPER_TIMINGS = {"walk-jog": (98, 0.108), "curved-walk": (111, 0.172), "uphill": (166, 0.211),
                 "curved-jump": (91, 0.14)}


@dataclass(frozen=True, eq=False)
class Example:
    """``name``, the edited ``motion``, the ``schedule`` the paper used, the captured ``reference``
    (or ``None``), where it came from (``source``) and the paper's section."""

    name: str
    motion: object
    schedule: str
    reference: object
    source: str
    section: str


def _arc(motion, degrees: float):
    """A circular arc as long as ``motion``'s path, starting where and as it starts."""
    from ..ops import PathCurve, motion_path

    path, s, psi = motion_path(motion)
    L = max(float(s[-1]), 0.5)
    k = np.radians(degrees) / L
    u = np.linspace(0.0, L, 12)
    local = np.column_stack([np.sin(k * u) / k, (1 - np.cos(k * u)) / k])       # along x, turning left
    h = float(psi[0])
    d = np.array([np.cos(h), np.sin(h)])
    n = np.array([-d[1], d[0]])
    return PathCurve(path[0] + local[:, :1] * d + local[:, 1:] * n)


def paper_examples(data_dir: str | Path | None = None) -> dict[str, Example]:
    """The four edited inputs (module docstring); real clips from ``data_dir`` (default
    :func:`mocomp.datasets.data_dir`), the synthetic walk without one (no run, no jump: the
    walk-jog and curved-jump examples are then left out)."""
    from ..datasets import data_dir as find_data
    from ..ops import PathCurve, blend, motion_path, path_edit, slope

    d = Path(data_dir) if data_dir is not None else find_data()
    out = {}
    if d is None:
        from ..ops.synthetic import synthetic_walk

        walk = synthetic_walk(duration=4.0, fps=30.0).motion
        out["curved-walk"] = Example("curved-walk", path_edit(walk, _arc(walk, 90.0)).motion, "ground-default",
                                     None, "synthetic walk (4 s, 30 fps) path-edited onto a 90 deg arc", "4.3")
        out["uphill"] = Example("uphill", slope(walk, 10.0).motion, "uphill", None,
                                "synthetic walk on a 10 deg slope", "4.4")
        return out
    from ..datasets import load

    w = d / "walks"
    walk = load(w / "bandai2_walk_normal_001.bvh")
    run = load(w / "bandai2_run_normal_001.bvh")
    turn = load(w / "bandai2_walk-turn-left_normal_001.bvh")
    out["walk-jog"] = Example("walk-jog", blend(walk, run, (120, 40), 20).motion, "default", run,
                              "Bandai-2 walk frames 0-129 blended into the Bandai-2 run from its frame 30 "
                              "(20-frame window)", "4.2")
    path, _, _ = motion_path(turn)
    out["curved-walk"] = Example("curved-walk", path_edit(walk, PathCurve(path[::10])).motion, "ground-default",
                                 turn, "Bandai-2 straight walk path-edited onto the path of the Bandai-2 "
                                 "left-turning walk", "4.3")
    out["uphill"] = Example("uphill", slope(walk, 10.0).motion, "uphill", None,
                            "Bandai-2 straight walk rotated onto a 10 deg slope", "4.4")
    jump = load(d / "jumps" / "01_01.bvh").slice(400, 500)
    out["curved-jump"] = Example("curved-jump", path_edit(jump, _arc(jump, 60.0)).motion, "default", jump,
                                 "CMU 01_01 forward hop frames 400-499 (120 Hz, one flight) path-edited onto a "
                                 "60 deg arc", "4.5")
    return out
