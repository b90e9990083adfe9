"""Touch-up schedules: sequences of adjustments with their link sets, time scale and damping
(touch-up paper, Shin et al. 2003, sec. 3.1 and 4.1).

A :class:`Step` adjusts ``stage`` (``"ground"``: the ZMP, sec. 3.3; ``"flight"``: angular momentum
and the ballistic COM, sec. 3.4) with link sets ``s1``/``s2``/``s3`` (presets or joint names,
:func:`mocomp.touchup.linksets.link_sets`), a smoothing kernel of width ``sigma`` and a damping
``rho``, for ``iterations`` iterations. Widths are kept in seconds so that a schedule means the same
on a 30 and a 120 fps clip; the paper's widths are frames of its 30 fps motions (its 15-frame flight
neighbourhood is "1/2 second"), so its 40, 20 and 10 frames are 4/3, 2/3 and 1/3 s.

The width is the paper's "filter kernel 40 frames wide" (sec. 4.1): the kernel's whole extent, not
a standard deviation. The Gaussian kernel (the default) spans it with +-3 standard deviations
(standard deviation ``width / 6``); the least-squares cubic B-spline (Lee & Shin's hierarchical
displacement maps) has its basis functions that wide (knots every ``width / 4``: a cubic B-spline
spans 4 knot intervals). Read as a standard deviation or a knot spacing, 40 frames smooths the
per-frame adjustments over a whole walk cycle and more, and the lean cannot follow the steps:
on the Bandai walk path-edited onto a curve, ``ground-default`` left 72 % of the mean ZMP distance
outside the support polygon that way, 5 % with the kernel 40 frames wide.

Presets (sec. 4.1, iterations from sec. 4.3: "five iterations [lower body], ... the upper body
five times followed by two iterations for the arms"): ``ground-default`` (lower S2 / upper S3, 40
frames, 0.5, x5; lower S1 / upper S2, 20, 0.3, x5; arms S2 / rest S1, 10, 0.2, x2),
``flight-default`` (lower S2 / upper S1, 10, 0.3; upper S2 / lower S1, 10, 0.3; all S2, 5, 1; once
each) and ``uphill`` (``ground-default`` with its first two steps swapped, sec. 4.4). A TOML file
lists ``[[step]]`` tables with the keys of :class:`Step` (``sigma`` in frames of the clip, or
``sigma_s`` in seconds).
"""
from __future__ import annotations

import tomllib
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..errors import MocompError

__all__ = ["Step", "ScheduleError", "PRESET_SCHEDULES", "preset_schedule", "read_schedule", "schedule_from_spec",
           "PAPER_FPS", "WIDTH_OVER_PARAMETER"]

#: the frame rate of the paper's motions (15 frames = 1/2 s, sec. 3.4)
PAPER_FPS = 30.0
KERNELS = ("gaussian", "bspline")
#: the kernel's whole width over its smoothing parameter: +-3 standard deviations of a Gaussian,
#: 4 knot intervals of a cubic B-spline (module docstring)
WIDTH_OVER_PARAMETER = {"gaussian": 6.0, "bspline": 4.0}


class ScheduleError(MocompError, ValueError):
    """A schedule file or step is malformed (the message names the file, step and field)."""


@dataclass(frozen=True)
class Step:
    """One adjustment: ``stage`` ground/flight, link sets, ``sigma_s`` s (the smoothing kernel's
    whole width), ``rho``, ``iterations``, ``kernel``."""

    stage: str
    s2: object
    s1: object = ()
    s3: object = ()
    sigma_s: float = 0.0
    rho: float = 1.0
    iterations: int = 1
    kernel: str = "gaussian"
    where: str = "step"

    def __post_init__(self):
        w = self.where
        if self.stage not in ("ground", "flight"):
            raise ScheduleError(f"{w}: stage must be 'ground' or 'flight', got {self.stage!r}")
        if not (isinstance(self.sigma_s, (int, float)) and np.isfinite(self.sigma_s) and self.sigma_s >= 0):
            raise ScheduleError(f"{w}: sigma must be 0 or more, got {self.sigma_s!r}")
        if not (isinstance(self.rho, (int, float)) and np.isfinite(self.rho) and 0 <= self.rho <= 1):
            raise ScheduleError(f"{w}: rho must be between 0 and 1, got {self.rho!r}")
        if not (isinstance(self.iterations, int) and self.iterations >= 1):
            raise ScheduleError(f"{w}: iterations must be a whole number >= 1, got {self.iterations!r}")
        if self.kernel not in KERNELS:
            raise ScheduleError(f"{w}: kernel must be one of {', '.join(KERNELS)}, got {self.kernel!r}")
        if self.stage == "flight" and self.s3 not in ((), [], "", None):
            raise ScheduleError(f"{w}: s3 must be empty on a flight step (the paper's closed forms, sec. 3.4)")

    def sigma_frames(self, fps: float) -> float:
        """The kernel's whole width in frames."""
        return float(self.sigma_s * fps)

    def kernel_parameter(self, fps: float) -> float:
        """Frames: the Gaussian's standard deviation or the B-spline's knot spacing of a kernel
        ``sigma_frames`` wide (:data:`WIDTH_OVER_PARAMETER`), what :func:`mocomp.ops.smooth_offsets` takes."""
        return self.sigma_frames(fps) / WIDTH_OVER_PARAMETER[self.kernel]

    def label(self) -> str:
        sets = ", ".join(f"{k}={_txt(v)}" for k, v in (("S1", self.s1), ("S2", self.s2), ("S3", self.s3)) if v)
        return f"{self.stage}: {sets}; sigma {self.sigma_s:.3g} s; rho {self.rho:g}; x{self.iterations}"

    def to_dict(self) -> dict:
        return {"stage": self.stage, "s1": _txt(self.s1), "s2": _txt(self.s2), "s3": _txt(self.s3),
                "sigma_s": self.sigma_s, "rho": self.rho, "iterations": self.iterations, "kernel": self.kernel}


def _txt(v) -> str:
    return v if isinstance(v, str) else "+".join(v)


def _paper(stage, frames, rho, iterations=1, **sets) -> Step:
    return Step(stage, sigma_s=frames / PAPER_FPS, rho=rho, iterations=iterations, where=f"preset {stage}", **sets)


_GROUND = (_paper("ground", 40, 0.5, 5, s2="lower", s3="upper"),
           _paper("ground", 20, 0.3, 5, s1="lower", s2="upper"),
           _paper("ground", 10, 0.2, 2, s1="rest", s2="arms"))
_FLIGHT = (_paper("flight", 10, 0.3, s1="upper", s2="lower"),
           _paper("flight", 10, 0.3, s1="lower", s2="upper"),
           _paper("flight", 5, 1.0, s2="all"))
PRESET_SCHEDULES = {
    "ground-default": _GROUND,
    "flight-default": _FLIGHT,
    "uphill": (_GROUND[1], _GROUND[0], _GROUND[2]),
    "default": _GROUND + _FLIGHT,
}


def preset_schedule(name: str) -> tuple[Step, ...]:
    if name not in PRESET_SCHEDULES:
        raise ScheduleError(f"unknown schedule {name!r}: one of {', '.join(PRESET_SCHEDULES)} or a .toml file")
    return PRESET_SCHEDULES[name]


_KEYS = {"stage", "s1", "s2", "s3", "sigma", "sigma_s", "rho", "iterations", "kernel"}


def read_schedule(path, fps: float) -> tuple[Step, ...]:
    """Steps of a TOML schedule file (``[[step]]`` tables; ``sigma`` in frames at ``fps``, or ``sigma_s``)."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as e:
        raise ScheduleError(f"schedule {path}: not valid TOML: {e}") from e
    rows = data.get("step")
    if not isinstance(rows, list) or not rows:
        raise ScheduleError(f"schedule {path}: no [[step]] tables")
    extra = set(data) - {"step"}
    if extra:
        raise ScheduleError(f"schedule {path}: unknown top-level key(s) {', '.join(sorted(extra))}")
    out = []
    for i, row in enumerate(rows, 1):
        where = f"schedule {path} step {i}"
        bad = set(row) - _KEYS
        if bad:
            raise ScheduleError(f"{where}: unknown field(s) {', '.join(sorted(bad))} (fields: {', '.join(sorted(_KEYS))})")
        for k in ("stage", "s2"):
            if k not in row:
                raise ScheduleError(f"{where}: missing field {k!r}")
        if "sigma" in row and "sigma_s" in row:
            raise ScheduleError(f"{where}: give sigma (frames) or sigma_s (seconds), not both")
        sig = row.get("sigma_s", 0.0)
        if "sigma" in row:
            s = row["sigma"]
            if not isinstance(s, (int, float)) or not np.isfinite(s) or s < 0:
                raise ScheduleError(f"{where}: sigma must be 0 or more frames, got {s!r}")
            sig = s / fps
        for k in ("s1", "s2", "s3"):
            v = row.get(k, [])
            if not (isinstance(v, str) or (isinstance(v, list) and all(isinstance(x, str) for x in v))):
                raise ScheduleError(f"{where}: {k} must be a preset or joint name or a list of them, got {v!r}")
        out.append(Step(row["stage"], row["s2"], row.get("s1", []), row.get("s3", []), sig, row.get("rho", 1.0),
                        row.get("iterations", 1), row.get("kernel", "gaussian"), where))
    return tuple(out)


def schedule_from_spec(spec: str | None, fps: float, iterations: int | None = None) -> tuple[Step, ...]:
    """A preset name or a ``.toml`` path (``None``: ``default``, ground then flight steps);
    ``iterations`` replaces every step's count."""
    spec = spec or "default"
    steps = read_schedule(spec, fps) if spec.endswith(".toml") else preset_schedule(spec)
    if iterations is not None:
        if int(iterations) < 1:
            raise ScheduleError(f"iterations must be at least 1, got {iterations}")
        steps = tuple(replace(s, iterations=int(iterations)) for s in steps)
    return steps
