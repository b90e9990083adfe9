"""Offscreen rendering (mocomp.plots.render3d) and stimulus-set rendering (study.render).

Small and fast: tiny images, few frames. Speed goals live in benchmarks/bench_render.py.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

from mocomp.core import Motion, Skeleton
from mocomp.core.skeleton import EndSite
from mocomp.plots import render3d as r3

RED = (1.0, 0.0, 0.0)


def figure_skeleton() -> Skeleton:
    names = ["Hips", "Spine", "Head", "LeftUpLeg", "LeftLeg", "LeftFoot", "RightUpLeg", "RightLeg", "RightFoot",
             "LeftArm", "LeftForeArm", "RightArm", "RightForeArm"]
    parents = [-1, 0, 1, 0, 3, 4, 0, 6, 7, 1, 9, 1, 11]
    offsets = [[0, 0.95, 0], [0, 0.25, 0], [0, 0.30, 0], [0.1, 0, 0], [0, -0.45, 0], [0, -0.42, 0],
               [-0.1, 0, 0], [0, -0.45, 0], [0, -0.42, 0], [0.18, 0.22, 0], [0.0, -0.28, 0], [-0.18, 0.22, 0],
               [0.0, -0.28, 0]]
    ends = [EndSite(2, [0, 0.2, 0], "Head_end"), EndSite(5, [0, -0.05, 0.12], "LeftFoot_end"),
            EndSite(8, [0, -0.05, 0.12], "RightFoot_end"), EndSite(10, [0, -0.25, 0], "LeftForeArm_end"),
            EndSite(12, [0, -0.25, 0], "RightForeArm_end")]
    return Skeleton(names, parents, offsets, end_sites=ends)


def standing(x: float = 0.0, n: int = 1, fps: float = 30.0) -> Motion:
    sk = figure_skeleton()
    rot = np.zeros((n, sk.n_joints, 4))
    rot[..., 3] = 1
    root = np.tile([x, 0.97, 0.0], (n, 1))
    return Motion(sk, fps, root, rot)


def spinning(n: int = 8, fps: float = 20.0) -> Motion:
    """The figure turning about z while moving along x (every frame different)."""
    m = standing(n=n, fps=fps)
    ang = np.linspace(0, np.pi, n)
    rot = np.array(m.rotations)
    rot[:, 0] = Rotation.from_rotvec(np.outer(ang, [0, 0, 1])).as_quat()
    root = np.array(m.root_positions)
    root[:, 0] = np.linspace(-0.5, 0.5, n)
    root[:, 1] += 0.3 * np.sin(ang)
    return m.replace(root_positions=root, rotations=rot)


CAM = r3.Camera(position=(0.0, 1.0, 6.0), focal_point=(0.0, 1.0, 0.0), view_angle=35.0)
SMALL = r3.RenderStyle(width=96, height=72, body_color=RED, shadow=True)


def red_mask(img: np.ndarray) -> np.ndarray:
    r, g, b = (img[..., k].astype(int) for k in range(3))
    return (r > 90) & (g < 0.55 * r) & (b < 0.55 * r)


# ------------------------------------------------------------------- style
def test_bone_kinds_for_common_rigs():
    kinds = {(figure_skeleton().names[b.joint], b.kind) for b in r3.bone_capsules(figure_skeleton())}
    for pair in [("LeftUpLeg", "thigh"), ("LeftLeg", "shin"), ("LeftArm", "upper_arm"), ("LeftForeArm", "forearm"),
                 ("Head", "head"), ("LeftFoot", "foot"), ("Hips", "torso")]:
        assert pair in kinds, pair
    # DeepMimic naming: right_hip -> right_knee is the thigh; chest -> right_shoulder a clavicle
    names = ["root", "chest", "neck", "right_hip", "right_knee", "right_ankle", "right_shoulder", "right_elbow"]
    sk = Skeleton(names, [-1, 0, 1, 0, 3, 4, 1, 6],
                  [[0, 0, 0], [0, .24, 0], [0, .22, 0], [0, 0, .08], [0, -.42, 0], [0, -.41, 0], [0, .02, .18],
                   [0, -.28, 0]], end_sites=[EndSite(2, [0, .2, 0], "head"), EndSite(7, [0, -.25, 0], "hand")])
    k = {(names[b.joint], b.kind) for b in r3.bone_capsules(sk)}
    assert {("right_hip", "thigh"), ("right_knee", "shin"), ("right_shoulder", "upper_arm"),
            ("neck", "head"), ("right_elbow", "forearm"), ("chest", "clavicle")} <= k
    # radii scale with body size
    small = r3.bone_capsules(figure_skeleton().scaled(0.5))
    big = r3.bone_capsules(figure_skeleton())
    assert np.allclose([b.radius for b in small], [0.5 * b.radius for b in big])


def test_fit_camera_frames_every_point():
    rng = np.random.default_rng(0)
    pts = rng.normal(size=(500, 3)) * [1.5, 0.6, 0.3] + [0.3, 1.2, 0.0]
    for el in (0.0, 10.0):
        cam = r3.fit_camera(pts, view_angle=30, aspect=4 / 3, margin=0.1, elevation=el, round_to=None)
        d = np.subtract(cam.focal_point, cam.position)
        d /= np.linalg.norm(d)
        right = np.cross(d, cam.view_up)
        right /= np.linalg.norm(right)
        up = np.cross(right, d)
        rel = pts - cam.position
        z = rel @ d
        assert np.all(z > 0)
        t = np.tan(np.radians(15))
        x, y = (rel @ right) / (z * t * 4 / 3), (rel @ up) / (z * t)
        assert np.abs(x).max() <= 1.0 and np.abs(y).max() <= 1.0
        assert max(np.abs(x).max(), np.abs(y).max()) > 0.6  # not absurdly far away
    with pytest.raises(ValueError):
        r3.fit_camera(pts, direction=(0, -1, 0))
    with pytest.raises(ValueError):
        r3.RenderStyle(width=95)


# -------------------------------------------------------------- rendering
def test_image_orientation_and_placement():
    left = r3.render_still(standing(-0.8), style=SMALL, camera=CAM)
    right = r3.render_still(standing(+0.8), style=SMALL, camera=CAM)
    assert left.shape == (72, 96, 3) and left.dtype == np.uint8
    ml, mr = red_mask(left), red_mask(right)
    assert ml.sum() > 80 and mr.sum() > 80
    cols = np.arange(96)
    assert (ml * cols).sum() / ml.sum() < 40 < 56 < (mr * cols).sum() / mr.sum()
    # not upside down: sky (background) on top, checkered ground at the bottom, head above feet
    bg = (np.array(SMALL.background) * 255).round()
    assert np.abs(left[0].astype(float) - bg).max() < 3
    assert left[-1].std() > 3  # ground checker
    rows = np.nonzero(ml.any(axis=1))[0]
    assert rows.min() < 30 and rows.max() > 40
    # shadow: darker pixels appear on the ground under the figure
    no_shadow = r3.render_still(standing(-0.8), style=r3.RenderStyle(width=96, height=72, body_color=RED,
                                                                     shadow=False), camera=CAM)
    assert (np.abs(no_shadow.astype(int) - left.astype(int)).sum(axis=2) > 30)[45:].sum() > 5


def test_frames_equal_fresh_stills_and_are_deterministic():
    m = spinning(6)
    with r3.MotionRenderer(m.skeleton, SMALL, CAM) as r:
        frames = list(r.frames(m))
    assert len(frames) == 6
    assert any(np.abs(frames[0].astype(int) - f.astype(int)).max() > 50 for f in frames[1:])
    for k in (0, 3, 5):
        still = r3.render_still(m, k, style=SMALL, camera=CAM)
        assert np.array_equal(still, frames[k]), k


def _read_video(path):
    import imageio_ffmpeg

    gen = imageio_ffmpeg.read_frames(str(path))
    meta = next(gen)
    w, h = meta["size"]
    return meta, [np.frombuffer(f, np.uint8).reshape(h, w, 3) for f in gen]


def test_video_roundtrip_and_deterministic_bytes(tmp_path):
    m = spinning(8, fps=20.0)
    res = r3.write_video(m, tmp_path / "a.mp4", style=SMALL, camera=CAM, poster=tmp_path / "a.png")
    assert res.n_frames == 8 and res.fps == 20.0 and res.duration_s == pytest.approx(0.4)
    meta, frames = _read_video(res.path)
    assert meta["codec"] == "h264" and meta["fps"] == 20.0 and tuple(meta["size"]) == (96, 72)
    assert "yuv420p" in meta["pix_fmt"] and len(frames) == 8
    with r3.MotionRenderer(m.skeleton, SMALL, CAM) as r:
        f5 = r.frame(m, 5)
    assert np.abs(frames[5].astype(float) - f5).mean() < 6  # lossy, but the same picture
    import imageio.v3 as iio

    assert np.array_equal(iio.imread(tmp_path / "a.png"), r3.render_still(m, 0, style=SMALL, camera=CAM))
    r3.write_video(m, tmp_path / "b.mp4", style=SMALL, camera=CAM)
    h = lambda p: hashlib.sha256(Path(p).read_bytes()).hexdigest()  # noqa: E731
    assert h(tmp_path / "a.mp4") == h(tmp_path / "b.mp4")
    # resampled to another rate: duration kept
    res = r3.write_video(m, tmp_path / "c.mp4", fps=40.0, style=SMALL, camera=CAM)
    assert res.n_frames == 15
    assert not list(tmp_path.glob("*.partial*"))


def test_filmstrip_layouts():
    m = spinning(8)
    ov = r3.render_filmstrip(m, n_poses=4, style=SMALL)
    assert ov.shape == (72, 96, 3)
    tiles = r3.render_filmstrip([m, m.translated((0, 0, 0.5))], n_poses=5, layout="tiles", style=SMALL)
    assert tiles.shape == (2 * 72, 5 * 96, 3)
    with pytest.raises(ValueError, match="skeleton"):
        r3.render_filmstrip([m, standing().replace(skeleton=figure_skeleton().scaled(0.9))], style=SMALL)
    with pytest.raises(ValueError, match="layout"):
        r3.render_filmstrip(m, layout="grid", style=SMALL)


_OSMESA_PROBE = (
    "import vtk\n"
    "w = vtk.vtkOSOpenGLRenderWindow()\n"
    "w.SetOffScreenRendering(1)\n"
    "w.SetSize(8, 8)\n"
    "w.AddRenderer(vtk.vtkRenderer())\n"
    "w.Render()\n"
    "print('osmesa ok')\n")


def _osmesa_unusable(code: str = _OSMESA_PROBE) -> str | None:
    """Why VTK's OSMesa window cannot be used on this host, or None when it renders: a bare VTK
    OSMesa render (no project code) in a fresh process, since without libOSMesa VTK prints
    "libOSMesa not found" and then crashes the process (SIGSEGV, rc -11) instead of raising."""
    try:
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                             env=dict(os.environ, VTK_DEFAULT_OPENGL_WINDOW="vtkOSOpenGLRenderWindow"))
    except subprocess.TimeoutExpired:
        return "a bare VTK OSMesa render did not finish in 120 s"
    if out.returncode == 0 and "osmesa ok" in out.stdout:
        return None
    how = f"killed by signal {-out.returncode}" if out.returncode < 0 else f"exit status {out.returncode}"
    said = "libOSMesa not found" if "libOSMesa not found" in out.stderr else (
        out.stderr.strip().splitlines() or ["no output"])[-1][-200:]
    return f"VTK's OSMesa backend is unusable here (a bare VTK OSMesa render: {how}; {said}); " \
           "scripts/setup-system.sh installs libosmesa6"


def test_osmesa_probe_reports_a_crash_instead_of_crashing():
    """The probe turns a crashing or failing render process into a reason (and a clean one into None)."""
    crash = _osmesa_unusable("import os, signal, sys\nsys.stderr.write('libOSMesa not found. It appears ...\\n')\n"
                             "os.kill(os.getpid(), signal.SIGSEGV)\n")
    assert crash is not None and "killed by signal 11" in crash and "libOSMesa not found" in crash
    fail = _osmesa_unusable("raise SystemExit('no display')")
    assert fail is not None and "exit status 1" in fail and "no display" in fail
    assert _osmesa_unusable("print('osmesa ok')") is None


def test_osmesa_backend_renders_the_same_picture(tmp_path):
    """The OSMesa fallback (libosmesa6) draws the same scene as EGL, in a fresh process. Skipped,
    saying why, when a bare VTK OSMesa render fails on this host (probed first in its own process:
    VTK segfaults without libOSMesa); a failure of the project's render after a good probe fails."""
    reason = _osmesa_unusable()
    if reason is not None:
        pytest.skip(reason)
    code = (
        "import sys, numpy as np; sys.path.insert(0, %r)\n"
        "from test_study_render import standing, SMALL, CAM\n"
        "from mocomp.plots import render3d as r3\n"
        "img = r3.render_still(standing(0.3), style=SMALL, camera=CAM)\n"
        "np.save(%r, img)\n" % (str(Path(__file__).parent), str(tmp_path / "os.npy")))
    env = dict(os.environ, VTK_DEFAULT_OPENGL_WINDOW="vtkOSOpenGLRenderWindow")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, f"rc {out.returncode}: {out.stderr[-2000:]}"
    os_img = np.load(tmp_path / "os.npy")
    egl = r3.render_still(standing(0.3), style=SMALL, camera=CAM)
    assert np.abs(os_img.astype(float) - egl).mean() < 2.0


# ------------------------------------------------------- stimulus sets
@pytest.fixture
def toy_example(monkeypatch):
    """A rigid tumbling flip as the embedded example ``_test_tumbling_flip`` (registered for
    this test only, so other tests never see it)."""
    import importlib

    from mocomp.datasets.examples import Example

    ex_mod = importlib.import_module("mocomp.datasets.examples")  # the package's `examples` is a function

    sys.path.insert(0, str(Path(__file__).parent))
    from test_study_stimuli import tumbling_flip

    class Res:
        def __init__(self):
            self.motion, self.body, self.flight = tumbling_flip(fps=60.0, n_stand=15, T=0.5, n_land=18)

    monkeypatch.setitem(ex_mod.EXAMPLES, "_test_tumbling_flip",
                        Example("_test_tumbling_flip", "test only: rigid tumbling flip", Res))


def _spec(tmp_path, **render):
    data = {"study": {"name": "tiny"},
            "render": dict({"width": 64, "height": 48, "fps": 15, "filmstrip": True, "filmstrip_poses": 3},
                           **render),
            "clip": {"pre_s": 0.1, "post_s": 0.15},
            "base": [{"id": "toy", "source": "example:_test_tumbling_flip"}],
            "condition": [{"perturbation": "am_abrupt", "directions": ["increase", "decrease"], "levels": [50]},
                          {"perturbation": "takeoff", "directions": ["increase"], "levels": [30]}]}
    p = tmp_path / "tiny.json"
    p.write_text(json.dumps(data))
    return p


def test_render_set_manifest_hashes_and_skipping(tmp_path, toy_example):
    from study.render import EXTRA_COLUMNS, MANIFEST_COLUMNS, render_stimulus_set

    spec = _spec(tmp_path)
    out = tmp_path / "out"
    rep = render_stimulus_set(spec, out, progress=False)
    m = rep.manifest
    assert list(m.columns[:len(MANIFEST_COLUMNS)]) == list(MANIFEST_COLUMNS)
    assert set(EXTRA_COLUMNS) <= set(m.columns)
    assert list(m["stimulus_id"]) == ["toy__none", "toy__am_abrupt_increase_50", "toy__am_abrupt_decrease_50",
                                      "toy__takeoff_increase_30"]
    assert rep.rendered == list(m["stimulus_id"]) and not rep.skipped
    for _, r in m.iterrows():
        f = out / r["file"]
        assert hashlib.sha256(f.read_bytes()).hexdigest() == r["sha256"]
        assert (out / r["poster"]).is_file() and (out / r["filmstrip"]).is_file()
        meta, frames = _read_video(f)
        assert len(frames) == r["n_frames"] and meta["fps"] == 15
        assert r["duration_s"] == pytest.approx(r["n_frames"] / 15)
    pert = m[m.perturbation != "none"]
    # (a full turn in 0.5 s at 60 fps: central differences under-read fast rotation by ~1 %)
    assert np.allclose(pert["achieved_error"], pert["nominal_level"], atol=1.5)
    # rotation-only (the default am_mode): every stimulus keeps the flight time and the COM path
    # (issue 19); the rotation speed changes at take-off and landing, measured
    fl = dict(zip(m.stimulus_id, m.flight_s))
    assert len({round(v, 9) for v in fl.values()}) == 1
    am = m[m.perturbation == "am_abrupt"].set_index("stimulus_id")
    assert (am["am_mode"] == "rotation").all() and (m["level_unit"] == "percent").all()
    assert (am["cue_com_change_m"] < 1e-3).all()
    assert am.at["toy__am_abrupt_increase_50", "cue_landing_rotation_ratio"] == pytest.approx(1.5 / 1.25, abs=0.03)
    assert am.at["toy__am_abrupt_decrease_50", "cue_takeoff_rotation_ratio"] == pytest.approx(1 / 0.75, abs=0.03)
    assert (m["base_correction_m"] < 1e-6).all()  # exact toy flight: nothing to correct
    info = json.loads((out / "render_info.json").read_text())
    assert info["n_stimuli"] == 4 and info["camera"]["view_angle"] == 30.0
    assert (out / "spec.json").is_file()
    # the trial-design side reads it
    from study.stimulus_set import load_manifest

    ss = load_manifest(out / "manifest.csv", verify_hashes=True)
    assert len(ss.ids) == 4 and ss.unperturbed == ["toy__none"]

    # unchanged -> nothing rendered, manifest identical
    before = (out / "manifest.csv").read_text()
    rep2 = render_stimulus_set(spec, out, progress=False)
    assert rep2.rendered == [] and len(rep2.skipped) == 4
    a = pd.read_csv(out / "manifest.csv").drop(columns=["render_s"])
    b = pd.read_csv(pd.io.common.StringIO(before)).drop(columns=["render_s"])
    pd.testing.assert_frame_equal(a, b)
    # a damaged video is rendered again, the others are not
    vid = out / m.loc[1, "file"]
    vid.write_bytes(vid.read_bytes()[:-10])
    rep3 = render_stimulus_set(spec, out, progress=False)
    assert rep3.rendered == ["toy__am_abrupt_increase_50"]
    assert pd.read_csv(out / "manifest.csv").loc[1, "sha256"] == m.loc[1, "sha256"]  # deterministic re-render
    # a style change (frame rate) re-renders everything
    rep4 = render_stimulus_set(_spec(tmp_path, fps=10), out, progress=False)
    assert len(rep4.rendered) == 4


def test_render_cli(tmp_path, capsys, toy_example):
    from study.render_cli import register_render

    parser = argparse.ArgumentParser(prog="mocomp study")
    register_render(parser.add_subparsers(dest="sub"))
    args = parser.parse_args(["render", str(_spec(tmp_path)), "-o", str(tmp_path / "o"), "--no-progress",
                              "--only", "toy__none", "toy__takeoff_increase_30"])
    assert args.func(args) == 0
    out = capsys.readouterr().out
    assert "2 stimuli" in out and "achieved vs nominal" in out
    assert len(pd.read_csv(tmp_path / "o" / "manifest.csv")) == 2
    # the full run reuses the two previews; a later preview keeps the full manifest
    from study.render import render_stimulus_set

    rep = render_stimulus_set(_spec(tmp_path), tmp_path / "o", progress=False)
    assert sorted(rep.skipped) == ["toy__none", "toy__takeoff_increase_30"] and len(rep.rendered) == 2
    rep = render_stimulus_set(_spec(tmp_path), tmp_path / "o", progress=False, only=["toy__none"])
    assert rep.rendered == [] and len(rep.manifest) == 4
    from mocomp.errors import StudyDataError

    args = parser.parse_args(["render", str(_spec(tmp_path)), "-o", str(tmp_path / "o"), "--only", "nope"])
    with pytest.raises(StudyDataError, match="unknown stimulus"):
        args.func(args)


def test_mocomp_study_render_command(tmp_path, toy_example):
    """Through the real ``mocomp`` entry point (once the ``study`` command exists)."""
    from mocomp.cli import COMMAND_MODULES, main

    if "study" not in COMMAND_MODULES:
        pytest.skip("the 'study' command is not registered yet")
    rc = main(["study", "render", str(_spec(tmp_path)), "-o", str(tmp_path / "o"), "--no-progress"])
    assert rc == 0 and (tmp_path / "o" / "manifest.csv").is_file()
    assert main(["study", "render", str(tmp_path / "missing.toml"), "-o", str(tmp_path / "o")]) == 2


def test_missing_real_data_fails_unless_skipped(tmp_path, toy_example, monkeypatch):
    """A required base without its data stops the render (naming MOCOMP_DATA_DIR and the flag);
    --skip-missing-data renders the rest and render_info.json lists what was skipped."""
    from mocomp.cli import main
    from mocomp.errors import DataNotFoundError
    from study.render import render_stimulus_set
    from study.spec import load_spec

    # the paper spec's real base is required (it was silently dropped before)
    paper = load_spec(Path(__file__).parents[1] / "stimuli" / "paper_table2.toml")
    assert [b.required for b in paper.bases] == [True, True, True]
    monkeypatch.delenv("MOCOMP_DATA_DIR", raising=False)
    data = json.loads(_spec(tmp_path).read_text())
    data["base"].append({"id": "real", "source": "clip:cmu_88_01_backflip"})
    spec = tmp_path / "with_real.json"
    spec.write_text(json.dumps(data))
    with pytest.raises(DataNotFoundError) as ei:
        render_stimulus_set(spec, tmp_path / "o1", progress=False)
    msg = str(ei.value)
    assert "'real'" in msg and "MOCOMP_DATA_DIR" in msg and "--skip-missing-data" in msg
    assert not (tmp_path / "o1" / "manifest.csv").exists()
    assert main(["study", "render", str(spec), "-o", str(tmp_path / "o2"), "--no-progress"]) == 2
    rep = render_stimulus_set(spec, tmp_path / "o3", progress=False, skip_missing_data=True)
    assert set(rep.manifest["base_clip"]) == {"toy"} and len(rep.manifest) == 4
    info = json.loads((tmp_path / "o3" / "render_info.json").read_text())
    assert info["skipped_bases"] == ["real"]
    assert any("'real' skipped" in n for n in info["notes"])
    # without the flag nothing was skipped
    rep = render_stimulus_set(_spec(tmp_path), tmp_path / "o4", progress=False)
    assert json.loads((tmp_path / "o4" / "render_info.json").read_text())["skipped_bases"] == []


# ------------------------------------------------------- the audit of each stimulus (issue #13 section 2)
def test_manifest_carries_each_stimulus_audit_against_its_source(tmp_path):
    from study.render import AUDIT_COLUMNS, EXTRA_COLUMNS, MANIFEST_COLUMNS, render_stimulus_set
    from study.spec import load_spec
    from study.stimuli import build_stimuli

    data = json.loads(_spec(tmp_path, filmstrip=False, fps=10).read_text())
    data["base"] = [{"id": "bf", "source": "example:backflip"}]
    data["condition"] = [{"perturbation": "am_abrupt", "directions": ["increase"], "levels": [50]},
                         {"perturbation": "takeoff", "directions": ["increase"], "levels": [30]}]
    spec = tmp_path / "bf.json"
    spec.write_text(json.dumps(data))
    rep = render_stimulus_set(spec, tmp_path / "o", progress=False)
    m = pd.read_csv(tmp_path / "o" / "manifest.csv", keep_default_na=False)
    assert list(m.columns) == list(MANIFEST_COLUMNS) + list(EXTRA_COLUMNS) + list(AUDIT_COLUMNS)
    row = {r["stimulus_id"]: r for r in m.to_dict("records")}
    # independently: audit each built stimulus' motion and its base with mocomp.audit
    from mocomp.audit import audit

    built = build_stimuli(load_spec(spec))
    base = built.bases[0]
    src = audit(base.motion, base.body)
    for st in built.stimuli:
        a = audit(st.motion, base.body)
        r = row[st.stimulus_id]
        assert r["audit_verdict"] == a.verdict and r["audit_violations"] == len(a.violations)
        assert r["audit_advisories"] == len(a.advisories)
        assert r["audit_source_verdict"] == src.verdict and r["audit_source_violations"] == len(src.violations)
        assert sum(int(x.split(":")[1]) for x in filter(None, r["audit_checks"].split(";"))) == len(a.violations)
        assert rep.audits[st.stimulus_id].against is not None
    # known answers: the control is its source (nothing new); a 50 % abrupt |L| change is an L_magnitude
    # violation (threshold 10 %) the source does not have; a 30 % take-off error adds 0.18 m/s at take-off,
    # below the audit's 0.5 m/s jump_min
    assert row["bf__none"]["audit_new_violations"] == 0 and row["bf__none"]["audit_new_checks"] == ""
    sid = "bf__am_abrupt_increase_50"
    assert "L_magnitude:1" in row[sid]["audit_new_checks"].split(";")
    assert row[sid]["audit_verdict"] == "fail" and row[sid]["audit_new_violations"] >= 1
    assert row["bf__takeoff_increase_30"]["audit_new_violations"] == 0
    # the set loads (with its audit columns checked)
    from study.stimulus_set import load_manifest

    assert len(load_manifest(tmp_path / "o" / "manifest.csv").ids) == 3


def test_a_skeleton_the_audit_cannot_measure_leaves_the_audit_columns_empty(tmp_path, toy_example, capsys):
    from study.render import AUDIT_COLUMNS
    from study.render_cli import register_render

    parser = argparse.ArgumentParser(prog="mocomp study")
    register_render(parser.add_subparsers(dest="sub"))
    args = parser.parse_args(["render", str(_spec(tmp_path, filmstrip=False)), "-o", str(tmp_path / "o"),
                              "--no-progress"])
    assert args.func(args) == 0
    cap = capsys.readouterr()
    assert "0 pass, 0 fail, 4 not audited (see the notes)" in cap.out
    assert "its stimuli are not audited (audit_* columns empty): no body-segment mapping" in cap.err
    m = pd.read_csv(tmp_path / "o" / "manifest.csv", keep_default_na=False)
    assert (m[list(AUDIT_COLUMNS)] == "").all().all()
    from study.stimulus_set import load_manifest

    assert len(load_manifest(tmp_path / "o" / "manifest.csv").ids) == 4


def test_old_manifests_load_and_bad_audit_values_are_named(tmp_path):
    from study.placeholders import make_placeholder_set
    from study.stimulus_set import load_manifest
    from mocomp.errors import StudyDataError

    ss = make_placeholder_set(tmp_path / "s", {("takeoff", "increase"): (20,)}, base_clips=("a",), n_frames=3)
    path = ss.path
    df = pd.read_csv(path)
    assert not any(c.startswith("audit_") for c in df.columns)     # an old / hand-made manifest
    assert len(load_manifest(path).ids) == len(df)
    for col, value, word in (("audit_verdict", "maybe", "'maybe' is not one of pass, fail"),
                             ("audit_violations", "-1", "is not a count"),
                             ("audit_new_violations", "1.5", "is not a count")):
        bad = df.copy()
        bad[col] = "pass" if col == "audit_verdict" else 0
        bad[col] = bad[col].astype(object)
        bad.loc[1, col] = value
        bad.to_csv(path, index=False)
        with pytest.raises(StudyDataError) as e:
            load_manifest(path)
        assert f"manifest.csv:3 [{col}]" in str(e.value) and word in str(e.value)


def test_audit_columns_match_the_data_dictionary():
    import re

    from study.render import AUDIT_COLUMNS

    md = (Path(__file__).parents[1] / "study" / "DATA_DICTIONARY.md").read_text()
    part = md.split("## manifest.csv: audit columns", 1)[1].split("\n## ", 1)[0]
    doc = [re.findall(r"`([a-z_]+)`", ln.split("|")[1])[0] for ln in part.splitlines()
           if ln.startswith("| `")]
    assert doc == list(AUDIT_COLUMNS)


def test_render_summary_warns_about_unperturbed_stimuli_with_new_violations(capsys):
    from study.render_cli import _print_audit

    m = pd.DataFrame({"stimulus_id": ["a__none", "a__am_abrupt_increase_50", "b__none"],
                      "perturbation": ["none", "am_abrupt", "none"],
                      "audit_verdict": ["fail", "fail", "pass"], "audit_new_violations": [1, 2, 0],
                      "audit_new_checks": ["floor_penetration:1", "L_magnitude:1;com_velocity_jump:1", ""]})
    _print_audit(m)
    cap = capsys.readouterr()
    assert "1 pass, 2 fail" in cap.out
    assert "am_abrupt: 1 of 1 with violations new or worse than their source (L_magnitude 1, com_velocity_jump 1)" \
        in cap.out
    warn = cap.err.strip().splitlines()
    assert len(warn) == 1 and warn[0].startswith("mocomp study render: warning: 1 unperturbed")
    assert "a__none (floor_penetration:1)" in warn[0] and "b__none" not in warn[0]
