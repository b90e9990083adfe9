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

__all__ = ["Example", "paper_examples", "PAPER_TIMINGS", "ZmpRise", "zmp_rise", "NOISE_SIGMAS"]

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


#: frames: the smoothing widths beside the audit's (2 frames) whose spread defines the input's ZMP
#: noise (:func:`zmp_rise`)
NOISE_SIGMAS = (1.5, 3.0)


@dataclass(frozen=True, eq=False)
class ZmpRise:
    """Per frame ``(T,)`` m: the ZMP distance outside the contact polygon of the ``input`` and the
    ``output`` (clipped at 0; NaN where undefined), their difference ``rise`` and the input's
    ``noise``; ``worst`` the frame of the largest rise, ``above`` the frames whose rise exceeds the
    noise by more than ``tol``."""

    input: np.ndarray
    output: np.ndarray
    noise: np.ndarray
    tol: float

    @property
    def rise(self) -> np.ndarray:
        return self.output - self.input

    @property
    def worst(self) -> int:
        r = self.rise
        return int(np.nanargmax(np.where(np.isfinite(r), r, -np.inf)))

    @property
    def above(self) -> np.ndarray:
        x = self.rise - self.noise
        return np.flatnonzero(np.isfinite(x) & (x > self.tol))

    def to_dict(self) -> dict:
        w = self.worst
        return {"worst_frame": w, "worst_rise_m": float(self.rise[w]), "noise_there_m": float(self.noise[w]),
                "input_there_m": float(self.input[w]), "output_there_m": float(self.output[w]),
                "frames_above_noise": self.above.tolist()}


def zmp_rise(edited, touched, body=None, *, sigmas=NOISE_SIGMAS, tol: float = 0.005) -> ZmpRise:
    """Issue 16's "never rises on any frame by more than the input's noise", per frame, on the
    motions as given (pass them written and read back): the ZMP distance outside the contact
    polygon (:func:`mocomp.touchup.measure.zmp_outside`, ``polygon="contact"``,
    ``floor="support"``) of ``edited`` and ``touched``, and the input's noise: how far the
    ``edited`` motion's own distance moves when the Gaussian smoothing before differentiation (the
    audit's 2 frames; the paper's "gaussian filter of width 5") is ``sigmas`` frames instead, the
    largest change per frame. The paper's remark (sec. 3.3) is that differentiation magnifies any
    noise; where eq. 4's vertical force is a small part of the weight (take-off, landing) that
    spread is tens of cm, in quiet stance a few mm. ``tol`` m: rises within noise + ``tol`` count
    as within (:attr:`ZmpRise.above`)."""
    from dataclasses import replace

    from ..audit import default_body
    from ..audit.thresholds import AuditThresholds
    from .measure import zmp_outside

    body = default_body(edited) if body is None else body
    if edited.n_frames != touched.n_frames:
        raise ValueError(f"edited and touched differ in frames: {edited.n_frames} vs {touched.n_frames}")

    def dist(m, sigma=None):
        th = None if sigma is None else replace(AuditThresholds(), zmp_smooth_sigma=float(sigma))
        return np.clip(zmp_outside(m, body, polygon="contact", floor="support", thresholds=th).distance, 0.0, None)

    d0, d1 = dist(edited), dist(touched)
    spread = np.zeros_like(d0)
    for s in sigmas:
        spread = np.fmax(spread, np.abs(dist(edited, s) - d0))
    return ZmpRise(d0, d1, np.where(np.isfinite(d0), spread, np.nan), float(tol))
