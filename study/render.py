"""Render a stimulus set: videos, posters, filmstrips and the manifest CSV.

``render_stimulus_set(spec, out_dir)`` builds every stimulus of a
specification (:mod:`study.stimuli`), renders each one headless in the same
style (:mod:`mocomp.plots.render3d`: same character, ground, lights and one
fixed camera for the whole set, all stimuli starting from the same take-off
position) and writes ``out_dir/manifest.csv``.

Layout of ``out_dir``::

    manifest.csv          one row per stimulus (columns: MANIFEST_COLUMNS + EXTRA_COLUMNS + AUDIT_COLUMNS)
    render_info.json      spec, camera, style, encoder, library versions, timings
    spec.toml|json        a copy of the specification
    videos/<id>.mp4       H.264 (yuv420p, +faststart) at the spec's frame rate
    posters/<id>.png      the poster frame (frame 0 by default: the take-off stance,
                          which gives nothing away)
    filmstrips/<id>.png   optional

Re-rendering is incremental: each stimulus has a *content hash* (its motion's
bytes, the style, camera, frame rate, encoder settings and the VTK/ffmpeg
versions). A stimulus whose hash matches the previous manifest's row and whose
video still has the recorded SHA-256 is not rendered again. Files are written
to a temporary name and renamed, and the manifest is replaced atomically, so an
interrupted run never leaves a half-written video behind a valid row.
"""
from __future__ import annotations

import hashlib
import json
import math
import os
import platform
import shutil
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from mocomp.errors import StudyDataError

from .spec import StudySpec, load_spec
from .stimuli import AUDIT_COLUMNS  # the audit of each stimulus (study/DATA_DICTIONARY.md, manifest.csv)

__all__ = ["MANIFEST_COLUMNS", "EXTRA_COLUMNS", "AUDIT_COLUMNS", "RenderReport", "render_stimulus_set", "content_hash",
           "study_camera", "study_style", "RENDERER_VERSION"]

#: Bump when the drawing code changes pixels for the same inputs (forces re-rendering).
RENDERER_VERSION = "1"

try:  # the trial-design side owns the manifest reader; keep one column list
    from .stimulus_set import MANIFEST_COLUMNS, sha256_file
except ImportError:  # pragma: no cover - only while that module does not exist
    MANIFEST_COLUMNS = ("stimulus_id", "base_clip", "perturbation", "direction", "nominal_level",
                        "achieved_error", "duration_s", "file", "poster", "sha256")

    def sha256_file(path, chunk=1 << 20):
        h = hashlib.sha256()
        with open(path, "rb") as f:
            for block in iter(lambda: f.read(chunk), b""):
                h.update(block)
        return h.hexdigest()

#: Further manifest columns written by the renderer (documented in ``stimuli/README.md``).
EXTRA_COLUMNS = (
    "achieved_signed_pct", "L_error_pct", "velocity_error_pct", "takeoff_angle_deg", "takeoff_angle_change_deg",
    "takeoff_speed_ms", "speed_ratio", "flight_s", "base_flight_s", "apex_m", "landing_shift_m",
    "takeoff_dv_ms", "landing_dv_ms", "takeoff_dv_added_ms", "landing_dv_added_ms", "landing_rate",
    "L_direction_change_deg", "com_capture_dev_m",
    # issue 19: how the error was made, and every cue the audit measures on the stimulus' frames
    "am_mode", "level_unit", "imposed_velocity_change_pct", "cue_flight_s", "cue_flight_change_s", "cue_apex_m",
    "cue_apex_change_m", "cue_takeoff_jump_ms", "cue_landing_jump_ms", "cue_takeoff_angle_deg",
    "cue_takeoff_angle_change_deg", "cue_L_change_pct", "cue_takeoff_rotation_ratio", "cue_landing_rotation_ratio",
    "cue_landing_rotation_speed_rads", "cue_com_change_m", "base_correction_m", "base_g_fit",
    "fps", "n_frames", "width", "height",
    "filmstrip", "content_hash", "base_source", "render_s",
)


@dataclass
class RenderReport:
    """What :func:`render_stimulus_set` did.

    Attributes
    ----------
    manifest_path: the written ``manifest.csv``.
    manifest: its table.
    rendered: ids rendered in this run; ``skipped``: ids whose content hash was unchanged.
    frames: video frames rendered in this run; ``seconds``: wall time of the whole run;
    render_seconds: time spent rendering + encoding videos; ``frames_per_second``: frames / render_seconds.
    notes: remarks (bases skipped for missing data, flight detection, ...).
    audits: stimulus id -> :class:`~mocomp.audit.AuditReport` of its motion against its source
        (every stimulus, rendered or not: the audit does not depend on the pixels).
    """

    manifest_path: Path
    manifest: pd.DataFrame
    rendered: list[str] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)
    frames: int = 0
    seconds: float = 0.0
    render_seconds: float = 0.0
    frames_per_second: float = float("nan")
    notes: list[str] = field(default_factory=list)
    audits: dict = field(default_factory=dict)


def _versions() -> dict:
    import imageio_ffmpeg
    import pyvista
    import vtk

    return {"vtk": vtk.vtkVersion.GetVTKVersion(), "pyvista": pyvista.__version__,
            "ffmpeg": imageio_ffmpeg.get_ffmpeg_version(), "imageio_ffmpeg": imageio_ffmpeg.__version__}


def study_style(spec: StudySpec):
    """The :class:`~mocomp.plots.render3d.RenderStyle` of a study (defaults + the spec's size)."""
    from mocomp.plots.render3d import RenderStyle

    return RenderStyle(width=spec.render.width, height=spec.render.height)


def study_camera(spec: StudySpec, motions) -> "Camera":  # noqa: F821
    """The one camera of a study: the spec's, or fitted to every joint of every stimulus
    (side view along -z: the somersault axis, see :mod:`study.stimuli`)."""
    from mocomp.plots.render3d import Camera, fit_camera

    cam = spec.render.camera
    if cam != "auto":
        return Camera(tuple(cam["position"]), tuple(cam["focal_point"]), tuple(cam.get("view_up", (0, 1, 0))),
                      float(cam.get("view_angle", spec.render.view_angle)))
    pts = np.concatenate([m.positions.reshape(-1, 3) for m in motions])
    return fit_camera(pts, view_angle=spec.render.view_angle, elevation=spec.render.elevation, aspect=spec.render.width / spec.render.height,
                      margin=spec.render.margin)


def _encoder(spec: StudySpec) -> dict:
    from mocomp.plots.render3d import ENCODER

    return dict(ENCODER, crf=spec.render.crf, preset=spec.render.preset)


def content_hash(motion, *, fps: float, style, camera, encoder: dict, poster_frame: int,
                 filmstrip: bool, filmstrip_poses: int, versions: dict) -> str:
    """SHA-256 (hex) of everything that determines a stimulus' rendered files."""
    h = hashlib.sha256()
    sk = motion.skeleton
    for arr in (sk.parents, sk.offsets, motion.root_positions, motion.rotations):
        a = np.ascontiguousarray(arr)
        h.update(str(a.dtype).encode() + str(a.shape).encode())
        h.update(a.tobytes())
    for e in sk.end_sites:
        h.update(f"{e.parent}:".encode() + np.ascontiguousarray(e.offset, dtype=float).tobytes())
    meta = {"motion_fps": motion.fps, "video_fps": fps, "style": style.as_dict(), "camera": camera.as_dict(),
            "encoder": encoder, "poster_frame": poster_frame, "filmstrip": filmstrip,
            "filmstrip_poses": filmstrip_poses, "renderer": RENDERER_VERSION, "versions": versions,
            "names": list(sk.names)}
    h.update(json.dumps(meta, sort_keys=True).encode())
    return h.hexdigest()


def _read_old_manifest(path: Path) -> dict[str, dict]:
    if not path.is_file():
        return {}
    try:
        df = pd.read_csv(path, dtype=str, keep_default_na=False)
    except Exception:  # an unreadable old manifest only disables skipping
        return {}
    if "stimulus_id" not in df.columns or "content_hash" not in df.columns:
        return {}
    return {r["stimulus_id"]: r for r in df.to_dict("records")}


def _fmt(v):
    if isinstance(v, (float, np.floating)):
        return float(v) + 0.0 if math.isfinite(v) else float("nan")  # + 0.0: no "-0" in the CSV
    return v


def render_stimulus_set(spec: StudySpec | str | Path, out_dir: str | Path, *, force: bool = False,
                        skip_missing_data: bool = False, only: list[str] | None = None,
                        progress: bool = True, workers: int | None = 0, scheduler: str | None = None) -> RenderReport:
    """Render every stimulus of ``spec`` into ``out_dir`` and write ``manifest.csv``.

    Parameters
    ----------
    spec: a :class:`~study.spec.StudySpec` or the path of a specification file.
    out_dir: output folder (created).
    force: re-render even stimuli whose content hash is unchanged.
    skip_missing_data: drop bases whose real data are missing (``MOCOMP_DATA_DIR``
        unset) instead of failing; the report's notes say which.
    only: render only these stimulus ids (previews); the manifest keeps the other
        stimuli's rows that are still valid (same content hash, intact video).
    progress: show a tqdm bar over stimuli.
    workers, scheduler: where the stimuli are rendered, each one an independent item of
        :func:`mocomp.batch.map_items`: ``workers=0`` (default) in this process, one after the other;
        ``workers=N`` on a local Dask cluster of N processes (``None``: one per core); ``scheduler`` on
        an existing Dask cluster (its workers must see ``out_dir``). The files are the same.
    """
    from tqdm.auto import tqdm

    from mocomp.batch import map_items

    from .stimuli import build_stimuli

    t_start = time.perf_counter()
    src_path = None
    if not isinstance(spec, StudySpec):
        src_path = Path(spec)
        spec = load_spec(src_path)
    elif spec.path is not None:
        src_path = spec.path
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    for sub in ("videos", "posters") + (("filmstrips",) if spec.render.filmstrip else ()):
        (out / sub).mkdir(exist_ok=True)

    built = build_stimuli(spec, skip_missing_data=skip_missing_data, progress=progress)
    stimuli, notes = built.stimuli, list(built.notes)
    if only is not None:
        known = {s.stimulus_id for s in stimuli}
        unknown = sorted(set(only) - known)
        if unknown:
            raise StudyDataError(f"--only names unknown stimulus id(s) {', '.join(unknown)}", src_path)
    if not stimuli:
        raise StudyDataError("no stimuli to render (all bases skipped?)", src_path)

    style = study_style(spec)
    camera = study_camera(spec, [s.motion for s in built.stimuli])
    enc = _encoder(spec)
    versions = _versions()
    fps = spec.render.fps
    manifest_path = out / "manifest.csv"
    old = {} if force else _read_old_manifest(manifest_path)

    report = RenderReport(manifest_path=manifest_path, manifest=pd.DataFrame(), notes=notes)
    rows = []
    bases = {b.id: b for b in built.bases}
    base_audits: dict[str, object] = {}
    # pass 1: what to render (a stimulus whose content hash and files are unchanged is kept)
    plan = []  # (stimulus, content hash, files, previous row or None, reuse)
    jobs: list[_RenderJob] = []
    for st in stimuli:
        sid = st.stimulus_id
        ch = content_hash(st.motion, fps=fps, style=style, camera=camera, encoder=enc,
                          poster_frame=spec.render.poster_frame, filmstrip=spec.render.filmstrip,
                          filmstrip_poses=spec.render.filmstrip_poses, versions=versions)
        vid_rel = f"videos/{sid}.mp4"
        pos_rel = f"posters/{sid}.png"
        fs_rel = f"filmstrips/{sid}.png" if spec.render.filmstrip else ""
        prev = old.get(sid)
        reuse = (prev is not None and prev.get("content_hash") == ch and (out / vid_rel).is_file()
                 and (out / pos_rel).is_file() and (not fs_rel or (out / fs_rel).is_file())
                 and sha256_file(out / vid_rel) == prev.get("sha256"))
        if only is not None and sid not in only and not reuse:
            # a preview run keeps the valid rows of the full set; stale ones are left out
            if prev is not None:
                notes.append(f"{sid}: out of date, left out of the manifest (not in --only)")
            continue
        plan.append((st, ch, (vid_rel, pos_rel, fs_rel), prev, reuse))
        if not reuse:
            jobs.append(_RenderJob(sid, st.base_clip, st.motion, str(out / vid_rel), str(out / pos_rel),
                                   str(out / fs_rel) if fs_rel else "", fps, style, camera, enc,
                                   spec.render.poster_frame, spec.render.filmstrip_poses))
    # pass 2: render them, each stimulus an independent item of mocomp.batch's mechanism (in this process
    # by default, on a Dask cluster with workers=N / scheduler=ADDRESS)
    done: dict[str, tuple] = {}
    bar = tqdm(total=len(jobs), desc=f"render {spec.name}", unit="stim", disable=not progress)
    try:
        for o in map_items(_render_job, jobs, workers=workers, scheduler=scheduler, name=f"study-render-{spec.name}"):
            if o.status != "ok":
                if o.exception is not None and o.status == "failed":
                    raise o.exception
                raise StudyDataError(f"stimulus {o.item.stimulus_id}: rendering {o.status}: {o.error}", src_path)
            done[o.item.stimulus_id] = o.value
            bar.update(1)
    finally:
        bar.close()
        if workers == 0 and scheduler is None:
            _close_renderers()
    # pass 3: the manifest rows, in the stimuli's order
    for st, ch, (vid_rel, pos_rel, fs_rel), prev, reuse in plan:
        sid = st.stimulus_id
        if reuse:
            report.skipped.append(sid)
            sha, n_frames, dur, rsec = prev["sha256"], int(prev["n_frames"]), float(prev["duration_s"]), \
                float(prev.get("render_s") or "nan")
        else:
            sha, n_frames, dur, rsec = done[sid]
            report.rendered.append(sid)
            report.frames += n_frames
            report.render_seconds += rsec
        row = {
            "stimulus_id": sid, "base_clip": st.base_clip, "perturbation": st.perturbation,
            "direction": st.direction, "nominal_level": st.nominal_level,
            "achieved_error": st.measures["achieved_error"], "duration_s": dur, "file": vid_rel,
            "poster": pos_rel, "sha256": sha,
        }
        for c in EXTRA_COLUMNS:
            if c in st.measures:
                row[c] = st.measures[c]
        binfo = bases[st.base_clip].info
        row["base_correction_m"] = binfo.get("ballistic_correction_m", float("nan"))
        row["base_g_fit"] = binfo.get("g_fit_before_correction", float("nan"))
        row.update({"fps": fps, "n_frames": n_frames, "width": style.width, "height": style.height,
                    "filmstrip": fs_rel, "content_hash": ch, "base_source": st.base_source, "render_s": rsec})
        row.update(_audit_columns(st, bases[st.base_clip], base_audits, report))
        rows.append({k: _fmt(v) for k, v in row.items()})

    df = pd.DataFrame(rows, columns=list(MANIFEST_COLUMNS) + list(EXTRA_COLUMNS) + list(AUDIT_COLUMNS))
    tmp = manifest_path.with_name(".manifest.csv.partial")
    df.to_csv(tmp, index=False, float_format="%.6g")
    os.replace(tmp, manifest_path)
    if src_path is not None and src_path.is_file():
        shutil.copyfile(src_path, out / ("spec" + src_path.suffix))
    report.manifest = df
    report.seconds = time.perf_counter() - t_start
    report.frames_per_second = report.frames / report.render_seconds if report.render_seconds > 0 else float("nan")
    info = {
        "study": spec.name, "title": spec.title, "reference": spec.reference,
        "spec": str(src_path) if src_path else None, "n_stimuli": len(df),
        "rendered": len(report.rendered), "skipped": len(report.skipped),
        "frames_rendered": report.frames, "render_seconds": round(report.render_seconds, 3),
        "frames_per_second": None if math.isnan(report.frames_per_second) else round(report.frames_per_second, 2),
        "total_seconds": round(report.seconds, 3), "camera": camera.as_dict(), "style": style.as_dict(),
        "encoder": enc, "video_fps": fps, "renderer_version": RENDERER_VERSION, "versions": versions,
        "opengl_window": os.environ.get("VTK_DEFAULT_OPENGL_WINDOW"), "platform": platform.platform(),
        "notes": notes, "skipped_bases": list(built.skipped_bases), "bases": built.base_info,
    }
    (out / "render_info.json").write_text(json.dumps(info, indent=2, default=_json_default) + "\n")
    return report


def _audit_columns(st, base, base_audits: dict, report: RenderReport) -> dict:
    """The manifest's audit columns of one stimulus (:func:`study.stimuli.audit_stimulus`), with its
    base's audit computed once; empty (and a note) when the audit cannot measure the skeleton."""
    from mocomp.errors import MocompError

    from .stimuli import audit_base, audit_stimulus

    try:
        if base.id not in base_audits:
            base_audits[base.id] = audit_base(base)
        if isinstance(base_audits[base.id], Exception):
            raise base_audits[base.id]
        report.audits[st.stimulus_id], cols = audit_stimulus(st, base, base_audits[base.id])
        return cols
    except MocompError as e:
        if base.id not in base_audits or not isinstance(base_audits[base.id], Exception):
            base_audits[base.id] = e
            report.notes.append(f"base {base.id!r}: its stimuli are not audited (audit_* columns empty): "
                                f"{' '.join(str(e).split())}")
        return {c: "" for c in AUDIT_COLUMNS}


def _json_default(o):
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    if isinstance(o, Path):
        return str(o)
    raise TypeError(f"not JSON-serializable: {type(o).__name__}")


@dataclass(frozen=True)
class _RenderJob:
    """One stimulus to render (picklable: it travels to a Dask worker)."""

    stimulus_id: str
    base_clip: str
    motion: object
    video: str
    poster: str
    filmstrip: str
    fps: float
    style: object
    camera: object
    encoder: dict
    poster_frame: int
    filmstrip_poses: int


#: open renderers of this process, one per (base clip, skeleton, style, camera): a scene is reused across
#: the stimuli of a base (in this process, or on each Dask worker)
_RENDERERS: dict = {}


def _close_renderers() -> None:
    while _RENDERERS:
        _RENDERERS.popitem()[1].close()


def _renderer(job: _RenderJob):
    from mocomp.plots.render3d import MotionRenderer

    key = (job.base_clip, tuple(job.motion.skeleton.names), json.dumps(job.style.as_dict(), sort_keys=True),
           json.dumps(job.camera.as_dict(), sort_keys=True, default=_json_default))
    if key not in _RENDERERS:
        if len(_RENDERERS) >= 8:  # a long-lived worker: keep a few scenes only
            _close_renderers()
        _RENDERERS[key] = MotionRenderer(job.motion.skeleton, job.style, job.camera)
    return _RENDERERS[key]


def _render_job(job: _RenderJob) -> tuple[str, int, float, float]:
    """Render one stimulus' video, poster (and filmstrip): ``(sha256 of the video, frames, duration_s,
    render seconds)``. Files are written by :func:`~mocomp.plots.render3d.write_video` (temporary name,
    then renamed)."""
    from mocomp.plots.render3d import RenderStyle, render_filmstrip, write_video

    res = write_video(job.motion, job.video, fps=job.fps, style=job.style, camera=job.camera, poster=job.poster,
                      poster_frame=job.poster_frame, encoder=job.encoder, renderer=_renderer(job))
    if job.filmstrip:
        style = job.style
        tile = RenderStyle(width=max(16, (style.width // 2) // 2 * 2), height=max(16, (style.height // 2) // 2 * 2))
        render_filmstrip(job.motion, n_poses=job.filmstrip_poses, layout="tiles", style=tile, camera=job.camera,
                         path=job.filmstrip)
    return sha256_file(job.video), res.n_frames, res.duration_s, res.seconds
