"""Placeholder stimulus sets: tiny synthetic MP4s with a valid manifest.

For piloting the harness, tests and demos without the renderer. Each video is
a small moving disc whose colour and path depend on the stimulus, so every
file (and its SHA-256) is distinct. They are *not* motion stimuli: never run a
real study on them.
"""
from __future__ import annotations

from pathlib import Path

import imageio_ffmpeg
import numpy as np
import pandas as pd

from .stimulus_set import MANIFEST_COLUMNS, StimulusSet, load_manifest, sha256_file

#: The paper's design (section 7 / Table 2): angular-momentum errors, abrupt and
#: smooth, up and down, at 17-50 %; take-off angle increases 10-40 %.
PAPER_LEVELS = {
    ("am_abrupt", "increase"): (17, 25, 37, 50),
    ("am_abrupt", "decrease"): (17, 25, 37, 50),
    ("am_smooth", "increase"): (17, 25, 37, 50),
    ("am_smooth", "decrease"): (17, 25, 37, 50),
    ("takeoff", "increase"): (10, 20, 30, 40),
}


def _frames(seed: int, n: int, w: int, h: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    colour = rng.integers(40, 255, size=3)
    y0, x0 = rng.uniform(0.2, 0.8, size=2)
    vx, vy = rng.uniform(-0.5, 0.5, size=2)
    yy, xx = np.mgrid[0:h, 0:w]
    out = np.empty((n, h, w, 3), np.uint8)
    out[:] = 235
    r = max(2, min(w, h) // 8)
    for t in range(n):
        cx = (x0 + vx * t / n) * w
        cy = (y0 + vy * t / n - 0.3 * (t / n) * (1 - t / n)) * h
        m = (xx - cx) ** 2 + (yy - cy) ** 2 <= r * r
        out[t][m] = colour
    return out


def write_mp4(path: str | Path, frames: np.ndarray, fps: float) -> None:
    """Write ``frames`` (T, H, W, 3) uint8 as H.264 MP4 (yuv420p; H and W even)."""
    frames = np.ascontiguousarray(frames, dtype=np.uint8)
    T, H, W, _ = frames.shape
    gen = imageio_ffmpeg.write_frames(str(path), (W, H), fps=fps, codec="libx264", pix_fmt_out="yuv420p",
                                      macro_block_size=1, quality=None,
                                      output_params=["-crf", "30", "-preset", "ultrafast", "-movflags", "+faststart"],
                                      ffmpeg_log_level="error")
    gen.send(None)
    for f in frames:
        gen.send(f)
    gen.close()


def make_placeholder_set(out_dir: str | Path, levels: dict | None = None, base_clips=("forward", "backward"),
                         *, fps: float = 15.0, n_frames: int = 12, size: tuple[int, int] = (64, 48),
                         seed: int = 0) -> StimulusSet:
    """Write placeholder videos and a manifest ``out_dir/manifest.csv``; return the loaded set.

    ``levels`` maps ``(perturbation, direction)`` to nominal levels (default
    :data:`PAPER_LEVELS`); each base clip gets one unperturbed stimulus and one
    per level. ``achieved_error`` is set equal to the nominal level (there is
    no motion to measure).
    """
    out_dir = Path(out_dir)
    (out_dir / "videos").mkdir(parents=True, exist_ok=True)
    levels = PAPER_LEVELS if levels is None else levels
    W, H = size
    rows = []
    k = 0
    for clip in base_clips:
        specs = [("none", "none", 0)] + [(p, d, lv) for (p, d), lvs in levels.items() for lv in lvs]
        for p, d, lv in specs:
            sid = f"{clip}__none" if p == "none" else f"{clip}__{p}_{d}_{lv:g}"
            rel = f"videos/{sid}.mp4"
            write_mp4(out_dir / rel, _frames(seed * 100003 + k, n_frames, W, H), fps)
            k += 1
            rows.append(dict(stimulus_id=sid, base_clip=clip, perturbation=p, direction=d, nominal_level=lv,
                             achieved_error=lv, duration_s=n_frames / fps, file=rel, poster="",
                             sha256=sha256_file(out_dir / rel)))
    pd.DataFrame(rows, columns=list(MANIFEST_COLUMNS)).to_csv(out_dir / "manifest.csv", index=False)
    return load_manifest(out_dir / "manifest.csv")
