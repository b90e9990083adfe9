"""C3D marker trajectories (via ``ezc3d``) into :class:`~mocomp.io.markers.Markers`.

* Lengths: ``POINT:UNITS`` (``mm``, ``cm``, ``m``) -> metres, unless ``scale`` is
  given; the factor is recorded in ``Markers.unit_scale``.
* Frame rate: ``POINT:RATE`` (``fps=`` overrides it, e.g. for a wrong header).
* Gaps: a sample is missing when its residual is negative (the C3D convention
  for an invalid point), when all three coordinates are exactly zero (how many
  exporters write gaps) or when it is not finite; it becomes NaN with
  ``mask == False``. Nothing else is altered.
* Axes: the library's world is y-up; C3D files are usually z-up (Vicon, HDM05).
  ``up="auto"`` reads ``POINT:Y_SCREEN`` (the axis drawn upwards, e.g. ``+Z``)
  and otherwise assumes z-up. The conversion is a proper rotation (no mirror):
  z-up ``(x, y, z) -> (x, z, -y)`` (-90 deg about x); x-up ``(x, y, z) -> (-z, x, -y)``;
  y-up unchanged. The mapping is recorded in ``Markers.notes``.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import MotionFormatError
from .markers import Markers
from .units import UNITS

__all__ = ["read_c3d", "UP_AXIS_MAPS"]

#: world (y-up) coordinates as a matrix times the file's (x, y, z), per file up axis
UP_AXIS_MAPS = {
    "y": np.eye(3),
    "z": np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]]),  # (x, z, -y)
    "x": np.array([[0.0, 0.0, -1.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]]),  # (-z, x, -y)
}
_MAP_TEXT = {"y": "(x, y, z) -> (x, y, z)", "z": "(x, y, z) -> (x, z, -y)", "x": "(x, y, z) -> (-z, x, -y)"}
_UNIT_ALIASES = {"mm": "mm", "millimeter": "mm", "millimeters": "mm", "cm": "cm", "m": "m", "meter": "m",
                 "meters": "m", "metre": "m", "metres": "m", "in": "inch", "inch": "inch", "inches": "inch"}


def _param(params: dict, group: str, name: str):
    try:
        return params[group][name]["value"]
    except (KeyError, TypeError):
        return None


def read_c3d(path, scale=None, up: str = "auto", fps: float | None = None, labeled_only: bool = False) -> Markers:
    """Read the 3-D points of a C3D file as :class:`Markers` in metres, y-up.

    Parameters
    ----------
    path: the ``.c3d`` file.
    scale: metres per file unit (number) or a unit name (``"mm"``, ...); default
        from ``POINT:UNITS``.
    up: the file's vertical axis, ``"x"``, ``"y"``, ``"z"`` or ``"auto"``
        (``POINT:Y_SCREEN`` if present, else ``"z"``); or a ``(3, 3)`` proper
        rotation taking file coordinates to the y-up world (e.g. HDM05's own
        AMC frame is the cyclic ``(x, y, z) -> (y, z, x)``, our z-up mapping
        yawed by 90 deg about the vertical; tested on the HDM05 sample).
    fps: override ``POINT:RATE``.
    labeled_only: drop unlabelled points (Vicon names them ``*0``, ``*1``, ...).
    """
    import ezc3d

    path = Path(path)
    if not path.is_file():
        raise MotionFormatError("no such file", path)
    try:
        c = ezc3d.c3d(str(path))
    except Exception as e:  # ezc3d raises plain RuntimeError/IOError for malformed files
        raise MotionFormatError(f"not a readable C3D file: {e}", path) from None
    params = c["parameters"]
    pts = np.asarray(c["data"]["points"], dtype=float)
    if pts.ndim != 3 or pts.shape[0] < 3:
        raise MotionFormatError(f"unexpected point block shape {pts.shape}", path)
    n_pts, T = pts.shape[1], pts.shape[2]
    if T == 0:
        raise MotionFormatError("the file has no frames", path)
    notes = []
    # ---- labels (LABELS, then LABELS2, LABELS3, ... for more than 255 points)
    labels = list(_param(params, "POINT", "LABELS") or [])
    k = 2
    while len(labels) < n_pts and _param(params, "POINT", f"LABELS{k}") is not None:
        labels += list(_param(params, "POINT", f"LABELS{k}"))
        k += 1
    labels = [str(s).strip() for s in labels[:n_pts]]
    if len(labels) < n_pts:
        notes.append(f"{n_pts - len(labels)} points had no label; named P<index>")
        labels += [f"P{i}" for i in range(len(labels), n_pts)]
    seen: dict[str, int] = {}
    for i, lab in enumerate(labels):
        if not lab:
            labels[i] = lab = f"P{i}"
        if lab in seen:
            seen[lab] += 1
            labels[i] = f"{lab}#{seen[lab]}"
            notes.append(f"duplicate label {lab!r} renamed {labels[i]!r}")
        else:
            seen[lab] = 1
    # ---- units
    if scale is None:
        u = _param(params, "POINT", "UNITS")
        unit = str(u[0]).strip().lower() if u else ""
        if unit not in _UNIT_ALIASES:
            raise MotionFormatError(f"POINT:UNITS is {unit!r}, not a known length unit; pass scale=...", path)
        s = UNITS[_UNIT_ALIASES[unit]]
        notes.append(f"POINT:UNITS '{unit}' -> {s:g} m per unit")
    elif isinstance(scale, str):
        if scale not in UNITS:
            raise ValueError(f"unknown unit {scale!r}; use a number or one of {sorted(UNITS)}")
        s = UNITS[scale]
        notes.append(f"unit '{scale}' given by caller")
    else:
        s = float(scale)
        if not (s > 0 and np.isfinite(s)):
            raise ValueError(f"scale must be positive, got {scale!r}")
        notes.append(f"scale {s:g} m/unit given by caller")
    # ---- rate
    rate = _param(params, "POINT", "RATE")
    header_rate = float(rate[0]) if rate is not None and len(rate) else float(c["header"]["points"]["frame_rate"])
    if fps is None:
        if not (np.isfinite(header_rate) and header_rate > 0):
            raise MotionFormatError(f"POINT:RATE is {header_rate}; pass fps=...", path)
        fps = header_rate
    else:
        notes.append(f"file rate {header_rate:g} Hz; caller set {fps:g} Hz")
    # ---- up axis
    if isinstance(up, str) and up == "auto":
        ys = _param(params, "POINT", "Y_SCREEN")
        tok = str(ys[0]).strip().upper() if ys else ""
        if tok in ("+X", "X", "+Y", "Y", "+Z", "Z"):
            up = tok[-1].lower()
            notes.append(f"up axis {up} from POINT:Y_SCREEN {tok!r}")
        else:
            up = "z"
            notes.append("up axis z assumed (no usable POINT:Y_SCREEN)")
    if isinstance(up, str):
        if up not in UP_AXIS_MAPS:
            raise ValueError(f"up must be 'x', 'y', 'z', 'auto' or a 3x3 rotation matrix, got {up!r}")
        R = UP_AXIS_MAPS[up]
        notes.append(f"axes to y-up: {_MAP_TEXT[up]}")
    else:
        R = np.asarray(up, dtype=float)
        if R.shape != (3, 3) or not np.allclose(R @ R.T, np.eye(3), atol=1e-9) or np.linalg.det(R) < 0:
            raise ValueError("up as a matrix must be a 3x3 proper rotation (orthonormal, det +1)")
        notes.append(f"axes to y-up: caller's matrix {np.round(R, 6).tolist()}")
    # ---- gaps
    xyz = pts[:3]  # (3, M, T)
    res = c["data"]["meta_points"].get("residuals") if "meta_points" in c["data"] else None
    seen_mask = np.all(np.isfinite(xyz), axis=0) & ~np.all(xyz == 0.0, axis=0)
    if res is not None and np.size(res):
        seen_mask &= ~(np.asarray(res)[0] < 0)
    P = np.einsum("ij,jmt->tmi", R, np.where(seen_mask[None], xyz, 0.0)) * s
    mask = seen_mask.T
    n_gaps = int((~mask).sum())
    if n_gaps:
        notes.append(f"{n_gaps} missing samples (of {mask.size}) set to NaN")
    first = c["header"]["points"].get("first_frame")
    if first is not None:
        notes.append(f"first frame number {first}")
    names = tuple(labels)
    if labeled_only:
        keep = [i for i, n in enumerate(names) if not n.startswith("*")]
        names = tuple(names[i] for i in keep)
        P, mask = P[:, keep], mask[:, keep]
        notes.append(f"{n_pts - len(keep)} unlabelled points dropped")
    return Markers(names, P, float(fps), mask, str(path), s, tuple(notes))
