"""Offscreen 3-D rendering of skeleton motions (PyVista/VTK): videos, stills, filmstrips.

One drawing style for every motion (the perception study needs the same
character, ground, lighting and camera for all its stimuli): each bone is a
capsule rigidly attached to its parent joint's frame, the head is a larger
capsule, the ground is a checkered plane at ``y = 0`` and each body casts a
planar (projected) shadow on it so that contact and height are visible.

Headless by design: :func:`configure_offscreen` selects VTK's EGL render window
(Mesa llvmpipe on machines without a GPU; no X server) or OSMesa, and
multisampling is off by default so that the output is deterministic and fast.
The frame loop moves actors through their user matrices, calls the render
window's ``Render()`` once per frame and reads the pixels back itself: PyVista's
``screenshot()`` path renders twice and is 2-4x slower (``benchmarks/bench_render.py``).

PyVista is imported lazily: ``import mocomp.plots.render3d`` does not load VTK.

Public API
----------
- :class:`RenderStyle`, :class:`Camera`, :func:`fit_camera`
- :class:`MotionRenderer` (context manager; ``frames()``, ``frame(i)``)
- :func:`write_video` (MP4 H.264 through imageio-ffmpeg) -> :class:`VideoResult`
- :func:`render_still`, :func:`render_filmstrip`, :func:`save_png`
- :func:`bone_capsules` (the character's geometry, for inspection/tests)
"""
from __future__ import annotations

import os
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Iterator, Sequence

import numpy as np

from ..core.motion import Motion
from ..core.skeleton import Skeleton

__all__ = [
    "configure_offscreen", "RenderStyle", "Camera", "fit_camera", "BoneCapsule", "bone_capsules",
    "MotionRenderer", "VideoResult", "write_video", "render_still", "render_filmstrip", "save_png",
    "joint_matrices", "video_frame_times", "same_skeleton", "add_lights", "add_ground", "add_characters",
    "apply_camera", "place_bones", "OffscreenScene", "rotate_about_y",
]

#: VTK render-window classes for headless rendering, by short name.
OFFSCREEN_WINDOWS = {"egl": "vtkEGLRenderWindow", "osmesa": "vtkOSOpenGLRenderWindow"}
_ENV = "VTK_DEFAULT_OPENGL_WINDOW"


def configure_offscreen(backend: str | None = None) -> str:
    """Choose VTK's headless render window before the first window is created.

    ``backend``: ``"egl"`` (default; Mesa llvmpipe without a GPU), ``"osmesa"``,
    or ``None`` to keep an already set ``$VTK_DEFAULT_OPENGL_WINDOW`` (else EGL).
    Returns the VTK class name in use. Needs the system libraries
    ``libegl1 libegl-mesa0 libgl1-mesa-dri`` (EGL) or ``libosmesa6`` (OSMesa).
    """
    if backend is None:
        cls = os.environ.get(_ENV) or OFFSCREEN_WINDOWS["egl"]
    else:
        if backend not in OFFSCREEN_WINDOWS:
            raise ValueError(f"offscreen backend must be one of {sorted(OFFSCREEN_WINDOWS)}, got {backend!r}")
        cls = OFFSCREEN_WINDOWS[backend]
    os.environ[_ENV] = cls
    return cls


# --------------------------------------------------------------------- style
@dataclass(frozen=True)
class RenderStyle:
    """Everything about the look of a rendering except the camera.

    Attributes
    ----------
    width, height: image size in pixels (even numbers; H.264 with yuv420p needs them).
    body_color: RGB in [0, 1] of the character (one colour for all bones).
    background: RGB of the sky.
    ground_colors: the two RGB colours of the checkered ground.
    ground_tile: checker tile size, metres.
    ground_half_size: the ground spans ``[-s, s]`` in x and z around ``ground_center``.
    ground_center: ``(x, z)`` of the ground's centre, metres.
    shadow: draw planar projected shadows on the ground.
    shadow_color: RGB of the shadow.
    light_direction: direction the key light (and the shadow projection) travels, world.
    radius_scale: multiplies every capsule radius.
    min_bone_length: bones shorter than this (metres) are not drawn (zero-length BVH joints).
    resolution: tessellation of the capsules (theta/phi segments).
    multi_samples: MSAA samples (0 = off: deterministic, fastest on llvmpipe).
    backend: ``"egl"``, ``"osmesa"`` or ``None`` (``$VTK_DEFAULT_OPENGL_WINDOW`` if set,
        else EGL; see :func:`configure_offscreen`).
    """

    width: int = 640
    height: int = 480
    body_color: tuple[float, float, float] = (0.80, 0.52, 0.30)
    background: tuple[float, float, float] = (0.86, 0.90, 0.95)
    ground_colors: tuple[tuple[float, float, float], tuple[float, float, float]] = (
        (0.78, 0.78, 0.76), (0.66, 0.66, 0.64))
    ground_tile: float = 0.5
    ground_half_size: float = 6.0
    ground_center: tuple[float, float] = (0.0, 0.0)
    shadow: bool = True
    shadow_color: tuple[float, float, float] = (0.42, 0.42, 0.42)
    light_direction: tuple[float, float, float] = (0.25, -1.0, -0.35)
    radius_scale: float = 1.0
    min_bone_length: float = 0.01
    resolution: int = 10
    multi_samples: int = 0
    backend: str | None = None

    def __post_init__(self):
        for name in ("width", "height"):
            v = getattr(self, name)
            if not (isinstance(v, (int, np.integer)) and 16 <= v <= 8192 and v % 2 == 0):
                raise ValueError(f"RenderStyle.{name} must be an even integer in [16, 8192], got {v!r}")
        if self.light_direction[1] >= 0:
            raise ValueError("RenderStyle.light_direction must point downwards (negative y) to cast shadows")
        if self.multi_samples < 0 or self.resolution < 4 or self.radius_scale <= 0:
            raise ValueError("RenderStyle: multi_samples >= 0, resolution >= 4, radius_scale > 0 required")
        if self.backend is not None and self.backend not in OFFSCREEN_WINDOWS:
            raise ValueError(f"RenderStyle.backend must be one of {sorted(OFFSCREEN_WINDOWS)}, got {self.backend!r}")

    def as_dict(self) -> dict:
        """Plain JSON-able dict (used in content hashes)."""
        import dataclasses

        d = dataclasses.asdict(self)
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in d.items()}


@dataclass(frozen=True)
class Camera:
    """A fixed perspective camera (world coordinates, metres, y-up).

    ``view_angle`` is the vertical field of view in degrees.
    """

    position: tuple[float, float, float]
    focal_point: tuple[float, float, float]
    view_up: tuple[float, float, float] = (0.0, 1.0, 0.0)
    view_angle: float = 30.0

    def __post_init__(self):
        for name in ("position", "focal_point", "view_up"):
            v = tuple(float(x) for x in getattr(self, name))
            if len(v) != 3 or not np.all(np.isfinite(v)):
                raise ValueError(f"Camera.{name} must be 3 finite numbers, got {getattr(self, name)!r}")
            object.__setattr__(self, name, v)
        if np.allclose(self.position, self.focal_point):
            raise ValueError("Camera.position equals its focal_point")
        if not (1.0 <= self.view_angle <= 150.0):
            raise ValueError(f"Camera.view_angle must be in [1, 150] degrees, got {self.view_angle}")

    def as_dict(self) -> dict:
        return {"position": list(self.position), "focal_point": list(self.focal_point),
                "view_up": list(self.view_up), "view_angle": float(self.view_angle)}


def fit_camera(points: np.ndarray, *, direction: Sequence[float] = (0.0, 0.0, -1.0), elevation: float = 0.0,
               view_angle: float = 30.0, aspect: float = 4.0 / 3.0, margin: float = 0.12,
               include_ground: bool = True, round_to: float | None = 0.01) -> Camera:
    """A fixed camera looking along ``direction`` that frames all ``points``.

    ``points``: ``(..., 3)`` world points (e.g. every joint of every frame of
    every stimulus: the same camera then serves them all). ``direction`` is the
    viewing direction (camera -> scene), default: from +z towards -z, which
    shows a somersault about the z axis side-on; ``elevation`` (degrees) tilts it
    to look down on the scene from above. ``margin`` is the fraction of
    the image left free around the points. With ``include_ground`` the floor
    point below the points' centre is included so the ground line is visible.
    ``round_to`` rounds the camera to a grid (metres) so tiny numerical
    differences do not change every content hash.
    """
    P = np.asarray(points, dtype=float).reshape(-1, 3)
    if P.size == 0 or not np.all(np.isfinite(P)):
        raise ValueError("fit_camera needs finite points")
    d = np.asarray(direction, dtype=float)
    d = d * np.array([1.0, 0.0, 1.0])
    if np.linalg.norm(d) < 1e-9:
        raise ValueError("fit_camera: viewing direction must not be vertical (use elevation to tilt)")
    d /= np.linalg.norm(d)
    el = np.radians(elevation)
    d = np.cos(el) * d - np.sin(el) * np.array([0.0, 1.0, 0.0])
    up0 = np.array([0.0, 1.0, 0.0])
    right = np.cross(d, up0)
    if np.linalg.norm(right) < 1e-6:
        raise ValueError("fit_camera: viewing direction must not be vertical")
    right /= np.linalg.norm(right)
    up = np.cross(right, d)
    if include_ground:
        c0 = 0.5 * (P.min(axis=0) + P.max(axis=0))
        P = np.vstack([P, [c0[0], 0.0, c0[2]]])
    u, v, w = P @ right, P @ up, P @ d
    cu, cv = 0.5 * (u.min() + u.max()), 0.5 * (v.min() + v.max())
    hu, hv = 0.5 * (u.max() - u.min()), 0.5 * (v.max() - v.min())
    t = np.tan(np.radians(view_angle) / 2.0) * (1.0 - margin)
    dist = max(hv / t, hu / (aspect * t), 0.5) + (w.max() - w.min()) * 0.5
    center = cu * right + cv * up + 0.5 * (w.min() + w.max()) * d
    pos = center - dist * d
    if round_to:
        center = np.round(center / round_to) * round_to
        pos = np.round(pos / round_to) * round_to
    return Camera(tuple(pos), tuple(center), tuple(up), view_angle)


# ----------------------------------------------------------------- character
@dataclass(frozen=True)
class BoneCapsule:
    """One drawn bone: a capsule from the origin of joint ``joint``'s frame to ``end``
    (in that frame, metres) with radius ``radius``; ``kind`` is the body part guessed
    from the joint names (torso, thigh, shin, foot, upper_arm, forearm, hand, neck, head, ...)."""

    joint: int
    end: np.ndarray
    radius: float
    kind: str

    @property
    def length(self) -> float:
        return float(np.linalg.norm(self.end))


#: Capsule radius per body part, as a fraction of the skeleton's rest height.
RADIUS_FRACTION = {
    "torso": 0.060, "pelvis": 0.045, "clavicle": 0.032, "neck": 0.030, "head": 0.060,
    "thigh": 0.046, "shin": 0.034, "foot": 0.024, "toe": 0.020,
    "upper_arm": 0.030, "forearm": 0.025, "hand": 0.020, "finger": 0.010, "other": 0.028,
}

_LANDMARKS = (  # (landmark, substrings) in priority order; matched on lower-cased joint names
    ("finger", ("finger", "thumb", "index", "pinky", "middle", "ring")),
    ("toe", ("toe",)),
    ("pelvis_side", ("hipjoint",)),
    ("pelvis", ("hips", "pelvis", "root")),
    ("elbow", ("forearm", "elbow", "lowerarm", "lower_arm")),
    ("shoulder", ("upperarm", "upper_arm", "humerus")),
    ("clavicle", ("clavicle", "collar")),
    ("shoulder_or_clavicle", ("shoulder",)),
    ("wrist", ("wrist", "hand")),
    ("knee", ("knee", "shin", "calf", "lowerleg", "lower_leg", "lowleg")),
    ("hip", ("upleg", "thigh", "upperleg", "upper_leg", "hip", "femur")),
    ("ankle", ("ankle", "foot")),
    ("head", ("head", "skull")),
    ("neck", ("neck",)),
    ("spine", ("spine", "back", "chest", "torso", "abdomen", "waist", "thorax", "lumbar")),
    ("arm", ("arm",)),
    ("leg", ("leg",)),
)


def _landmark(name: str) -> str:
    n = name.lower()
    for lm, keys in _LANDMARKS:
        if any(k in n for k in keys):
            return lm
    return "other"


def _bone_kind(parent_lm: str, child_lm: str | None) -> str:
    """Body part of the bone from a joint with landmark ``parent_lm`` to a child
    (``child_lm``; ``None`` for an end site)."""
    p, c = parent_lm, child_lm
    if c is None:  # end sites
        return {"head": "head", "neck": "head", "toe": "toe", "ankle": "foot", "wrist": "hand",
                "finger": "finger", "knee": "shin", "leg": "shin", "elbow": "forearm"}.get(p, "other")
    if c in ("finger",):
        return "finger" if p == "finger" else "hand"
    if c == "toe":
        return "foot"
    if c == "ankle":
        return "shin"
    if c in ("knee", "leg"):
        return "thigh"
    if c == "wrist":
        return "forearm"
    if c in ("elbow",):
        return "upper_arm"
    if c in ("arm", "shoulder", "shoulder_or_clavicle", "clavicle"):
        if p in ("shoulder", "shoulder_or_clavicle") and c in ("elbow",):
            return "upper_arm"
        return "clavicle"
    if c in ("hip", "pelvis_side"):
        return "pelvis"
    if c == "head":
        return "neck" if p in ("neck", "head") else "torso"
    if c == "neck":
        return "neck" if p == "neck" else "torso"
    if c in ("spine", "pelvis"):
        return "torso"
    return "other"


def bone_capsules(skeleton: Skeleton, style: RenderStyle | None = None) -> list[BoneCapsule]:
    """The character: one capsule per bone (joint -> child joint or end site).

    Radii are fractions (:data:`RADIUS_FRACTION`) of the skeleton's rest height,
    chosen per body part from the joint names of common rigs (CMU, SFU, Bandai,
    MASS, DeepMimic, the synthetic skeletons); unknown parts get a middle
    radius. Bones shorter than ``style.min_bone_length`` are skipped.
    """
    style = style or RenderStyle()
    h = max(skeleton.height(), 0.5)
    lm = [_landmark(n) for n in skeleton.names]
    out: list[BoneCapsule] = []
    for c in range(1, skeleton.n_joints):
        p = int(skeleton.parents[c])
        off = np.asarray(skeleton.offsets[c], dtype=float)
        if np.linalg.norm(off) < style.min_bone_length:
            continue
        kind = _bone_kind(lm[p], lm[c])
        out.append(BoneCapsule(p, off.copy(), RADIUS_FRACTION[kind] * h * style.radius_scale, kind))
    for e in skeleton.end_sites:
        off = np.asarray(e.offset, dtype=float)
        if np.linalg.norm(off) < style.min_bone_length:
            continue
        kind = _bone_kind(lm[e.parent], None)
        out.append(BoneCapsule(e.parent, off.copy(), RADIUS_FRACTION[kind] * h * style.radius_scale, kind))
    if not out:
        raise ValueError("skeleton has no bone longer than min_bone_length; nothing to draw")
    return out


def _capsule_mesh(b: BoneCapsule, resolution: int):
    import pyvista as pv

    L = b.length
    d = b.end / L
    return pv.Capsule(center=tuple(0.5 * b.end), direction=tuple(d), radius=b.radius,
                      cylinder_length=max(L, 1e-6), resolution=resolution).triangulate()


def joint_matrices(motion: Motion) -> np.ndarray:
    """``(T, J, 4, 4)`` homogeneous world transforms of every joint frame."""
    from scipy.spatial.transform import Rotation

    P, G = motion.fk()
    T, J = P.shape[:2]
    M = np.zeros((T, J, 4, 4))
    M[..., :3, :3] = Rotation.from_quat(G.reshape(-1, 4)).as_matrix().reshape(T, J, 3, 3)
    M[..., :3, 3] = P
    M[..., 3, 3] = 1.0
    return M


def _shadow_matrix(light_direction, y0: float = 0.004) -> np.ndarray:
    """Planar projection onto the plane ``y = y0`` along ``light_direction``."""
    dx, dy, dz = (float(v) for v in light_direction)
    S = np.eye(4)
    S[0, 1], S[0, 3] = -dx / dy, dx / dy * y0
    S[1, 1], S[1, 3] = 0.0, y0
    S[2, 1], S[2, 3] = -dz / dy, dz / dy * y0
    return S


def _checker_texture(colors):
    import pyvista as pv

    a = (np.asarray(colors[0]) * 255).round().astype(np.uint8)
    b = (np.asarray(colors[1]) * 255).round().astype(np.uint8)
    img = np.empty((2, 2, 3), np.uint8)
    img[0, 0] = img[1, 1] = a
    img[0, 1] = img[1, 0] = b
    tex = pv.Texture(img)
    tex.repeat = True
    tex.interpolate = False
    return tex



# ------------------------------------------------------------- scene parts
def rotate_about_y(v, yaw: float) -> np.ndarray:
    """``v`` (``(..., 3)``) rotated by ``yaw`` radians about the vertical (y) axis."""
    c, s = np.cos(yaw), np.sin(yaw)
    v = np.asarray(v, float)
    return np.stack([c * v[..., 0] + s * v[..., 2], v[..., 1], -s * v[..., 0] + c * v[..., 2]], axis=-1)


def add_lights(pl, style: RenderStyle, only_active: bool = False, yaw: float = 0.0) -> None:
    """Key light (along ``style.light_direction``, the shadows' light), fill light and a head light
    on the plotter ``pl`` (its active renderer only with ``only_active``: one panel of several).
    ``yaw`` turns the key and fill lights about the vertical (a camera looking along another
    direction than -z then sees the lit side, as the study's camera does)."""
    import pyvista as pv

    ld = np.asarray(style.light_direction, float)
    ld = rotate_about_y(ld / np.linalg.norm(ld), yaw)
    key = pv.Light(position=tuple(-ld * 10.0), focal_point=(0, 0, 0), intensity=0.85, light_type="scene light")
    fill = pv.Light(position=tuple(rotate_about_y((-3.0, 2.0, 6.0), yaw)), focal_point=(0, 0, 0), intensity=0.35,
                    light_type="scene light")
    head = pv.Light(intensity=0.25, light_type="headlight")
    for lt in (key, fill, head):
        pl.add_light(lt, only_active=only_active)


def add_ground(pl, style: RenderStyle):
    """The checkered ground plane at ``y = 0`` on ``pl``'s active renderer; returns its actor."""
    import pyvista as pv

    gs, gc = style.ground_half_size, style.ground_center
    plane = pv.Plane(center=(gc[0], 0.0, gc[1]), direction=(0, 1, 0), i_size=2 * gs, j_size=2 * gs,
                     i_resolution=1, j_resolution=1)
    tiles = 2 * gs / style.ground_tile
    tc = np.asarray(plane.active_texture_coordinates) * (tiles / 2.0)
    plane.active_texture_coordinates = tc
    return pl.add_mesh(plane, texture=_checker_texture(style.ground_colors), ambient=0.45, diffuse=0.6,
                       specular=0.0, reset_camera=False)


def add_characters(pl, style: RenderStyle, capsules, colors) -> tuple[list, list, list]:
    """One copy of the capsule character per colour in ``colors`` on ``pl``'s active renderer.

    Returns ``(mats, shadow_mats, actors)``, one list per character: the ``vtkMatrix4x4`` user
    matrix of each bone actor, of each shadow actor (empty without shadows), and all its actors
    (bones and shadows interleaved)."""
    import vtk

    meshes = [_capsule_mesh(b, style.resolution) for b in capsules]
    # flat grey silhouettes need fewer facets (halves the triangles llvmpipe sets up)
    smeshes = [_capsule_mesh(b, max(4, style.resolution // 2 + 1)) for b in capsules]
    all_mats, all_smats, all_acts = [], [], []
    for color in colors:
        mats, smats, acts = [], [], []
        for mesh, smesh in zip(meshes, smeshes):
            a = pl.add_mesh(mesh, color=tuple(color), smooth_shading=True, ambient=0.25, diffuse=0.75,
                            specular=0.15, specular_power=20.0, reset_camera=False)
            m = vtk.vtkMatrix4x4()
            a.SetUserMatrix(m)
            mats.append(m)
            acts.append(a)
            if style.shadow:
                s = pl.add_mesh(smesh, color=style.shadow_color, lighting=False, reset_camera=False)
                sm = vtk.vtkMatrix4x4()
                s.SetUserMatrix(sm)
                smats.append(sm)
                acts.append(s)
        all_mats.append(mats)
        all_smats.append(smats)
        all_acts.append(acts)
    return all_mats, all_smats, all_acts


def apply_camera(vtk_camera, camera: Camera) -> None:
    """Set a VTK/PyVista camera from a :class:`Camera`."""
    vtk_camera.position = camera.position
    vtk_camera.focal_point = camera.focal_point
    vtk_camera.up = camera.view_up
    vtk_camera.view_angle = camera.view_angle
    vtk_camera.clipping_range = (0.05, 200.0)


def place_bones(mats, shadow_mats, S: np.ndarray, B: np.ndarray) -> None:
    """Copy the bone transforms ``B`` ``(n_bones, 4, 4)`` into the bone actors' user matrices
    ``mats`` and their planar projections ``S @ B`` into ``shadow_mats`` (may be empty)."""
    for m, b in zip(mats, B):
        m.DeepCopy(b.ravel())
    if shadow_mats:
        for m, b in zip(shadow_mats, S @ B):
            m.DeepCopy(b.ravel())


def same_skeleton(a: Skeleton, b: Skeleton) -> bool:
    """Same joints, hierarchy, offsets and end sites (one character can draw both)."""
    if a is b:
        return True
    return (a.names == b.names and np.array_equal(a.parents, b.parents) and np.allclose(a.offsets, b.offsets)
            and len(a.end_sites) == len(b.end_sites)
            and all(x.parent == y.parent and np.allclose(x.offset, y.offset) for x, y in zip(a.end_sites, b.end_sites)))


def video_frame_times(duration: float, fps: float) -> np.ndarray:
    """Times ``0, 1/fps, ...`` up to ``duration`` (inclusive within 1e-9 s)."""
    n = int(np.floor(duration * fps + 1e-9)) + 1
    return np.arange(n) / fps


class OffscreenScene:
    """Owner of an offscreen PyVista plotter (``self._pl``): ``close()``, a context manager, and the
    pixel read-back of its window."""

    _pl = None

    def read_pixels(self, width: int, height: int) -> np.ndarray:
        """Render the window once and return its ``(height, width, 3)`` uint8 pixels, top row first."""
        if not hasattr(self, "_arr"):
            import vtk
            from vtk.util.numpy_support import vtk_to_numpy

            self._arr = vtk.vtkUnsignedCharArray()
            self._to_numpy = vtk_to_numpy
        rw = self._pl.ren_win
        rw.Render()
        rw.GetPixelData(0, 0, width - 1, height - 1, 0, self._arr, 0)
        return self._to_numpy(self._arr).reshape(height, width, 3)[::-1].copy()

    def close(self) -> None:
        if getattr(self, "_pl", None) is not None:
            self._pl.close()
            self._pl = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):  # pragma: no cover
        try:
            self.close()
        except Exception:
            pass


class MotionRenderer(OffscreenScene):
    """A headless scene holding one or more characters; renders frames to arrays.

    Use as a context manager (it owns a VTK render window)::

        with MotionRenderer(motion.skeleton, style, camera) as r:
            for img in r.frames(motion):   # (H, W, 3) uint8 arrays
                ...

    ``n_characters`` > 1 draws several copies of the skeleton (filmstrips,
    side-by-side comparisons); ``colors`` gives each its RGB colour.
    """

    def __init__(self, skeleton: Skeleton, style: RenderStyle | None = None, camera: Camera | None = None,
                 *, n_characters: int = 1, colors: Sequence[Sequence[float]] | None = None):
        self.style = style = style or RenderStyle()
        configure_offscreen(style.backend)
        import pyvista as pv

        self.skeleton = skeleton
        self.camera = camera
        self.capsules = bone_capsules(skeleton, style)
        self._bone_joint = np.array([b.joint for b in self.capsules])
        self._S = _shadow_matrix(style.light_direction)
        colors = list(colors) if colors is not None else [style.body_color] * n_characters
        if len(colors) != n_characters:
            raise ValueError(f"{n_characters} characters but {len(colors)} colours")
        self.n_characters = n_characters

        pl = pv.Plotter(off_screen=True, window_size=(style.width, style.height), lighting="none")
        self._pl = pl
        pl.ren_win.SetMultiSamples(int(style.multi_samples))
        pl.set_background(style.background)
        add_lights(pl, style)
        self.ground_actor = add_ground(pl, style)
        # Characters: one actor per bone (and per shadow), moved by user matrices.
        self._mats, self._shadow_mats, self._actors = add_characters(pl, style, self.capsules, colors)
        if camera is not None:
            self.set_camera(camera)
        self.render_seconds = 0.0

    # -- scene control
    def set_camera(self, camera: Camera) -> None:
        self.camera = camera
        apply_camera(self._pl.camera, camera)

    def set_pose(self, character: int, M: np.ndarray) -> None:
        """Place character ``character`` with joint transforms ``M`` ``(J, 4, 4)``."""
        place_bones(self._mats[character], self._shadow_mats[character], self._S, M[self._bone_joint])

    def set_visible(self, character: int, visible: bool) -> None:
        for a in self._actors[character]:
            a.SetVisibility(bool(visible))

    def snapshot(self) -> np.ndarray:
        """Render the scene once and return ``(H, W, 3)`` uint8 (top row first)."""
        if self.camera is None:
            raise ValueError("MotionRenderer has no camera: pass camera= or call set_camera()")
        t0 = time.perf_counter()
        img = self.read_pixels(self.style.width, self.style.height)
        self.render_seconds += time.perf_counter() - t0
        return img

    def frame(self, motion: Motion, i: int, character: int = 0) -> np.ndarray:
        """Image of frame ``i`` of ``motion``."""
        M = joint_matrices(motion[i])[0]
        self.set_pose(character, M)
        return self.snapshot()

    def frames(self, motion: Motion, character: int = 0, progress: bool | str = False) -> Iterator[np.ndarray]:
        """Images of every frame of ``motion`` in order (a generator)."""
        if not same_skeleton(motion.skeleton, self.skeleton):
            raise ValueError("motion's skeleton differs from the renderer's")
        M = joint_matrices(motion)
        it = range(M.shape[0])
        if progress:
            from tqdm.auto import tqdm

            it = tqdm(it, desc=progress if isinstance(progress, str) else "render", unit="frame", leave=False)
        for t in it:
            self.set_pose(character, M[t])
            yield self.snapshot()



# ------------------------------------------------------------------- outputs
@dataclass(frozen=True)
class VideoResult:
    """What :func:`write_video` wrote and how long it took.

    Attributes
    ----------
    path: the MP4 file.
    n_frames: frames written.
    fps: playback frame rate of the file.
    duration_s: ``n_frames / fps``.
    seconds: wall time (scene set-up + render + encode).
    render_seconds: time in VTK render + pixel read-back.
    frames_per_second: ``n_frames / seconds``.
    poster: the poster PNG if one was written.
    encoder: codec and its settings.
    """

    path: Path
    n_frames: int
    fps: float
    duration_s: float
    seconds: float
    render_seconds: float
    frames_per_second: float
    poster: Path | None = None
    encoder: dict = field(default_factory=dict)


#: ffmpeg settings of every video (part of the stimulus content hash).
ENCODER = {"codec": "libx264", "crf": 18, "preset": "veryfast", "pix_fmt": "yuv420p", "threads": 2}


def _open_writer(path: Path, width: int, height: int, fps: float, encoder: dict):
    import imageio_ffmpeg

    params = ["-crf", str(encoder["crf"]), "-preset", encoder["preset"], "-threads", str(encoder["threads"]),
              "-movflags", "+faststart", "-map_metadata", "-1", "-fflags", "+bitexact", "-flags:v", "+bitexact"]
    gen = imageio_ffmpeg.write_frames(str(path), (width, height), fps=fps, codec=encoder["codec"], quality=None,
                                      pix_fmt_in="rgb24", pix_fmt_out=encoder["pix_fmt"], macro_block_size=2,
                                      output_params=params, ffmpeg_log_level="error")
    gen.send(None)
    return gen


def write_video(motion: Motion, path: str | Path, *, fps: float | None = None, style: RenderStyle | None = None,
                camera: Camera | None = None, poster: str | Path | None = None, poster_frame: int = 0,
                encoder: dict | None = None, progress: bool | str = False,
                renderer: MotionRenderer | None = None) -> VideoResult:
    """Render ``motion`` to an MP4 (H.264, yuv420p, ``+faststart`` for web playback).

    The motion is resampled to the video rate ``fps`` (default: its own) by
    :meth:`Motion.sample` (slerp), so the file plays in real time. ``camera``
    defaults to :func:`fit_camera` on this motion (pass one camera for a set of
    videos that must share it). ``poster`` writes frame ``poster_frame`` as
    PNG. Pass an open ``renderer`` to reuse its scene across videos of the
    same skeleton (faster).
    """
    t0 = time.perf_counter()
    style = style or (renderer.style if renderer else RenderStyle())
    fps = float(motion.fps if fps is None else fps)
    if not (np.isfinite(fps) and fps > 0):
        raise ValueError(f"video fps must be positive, got {fps}")
    m = motion if abs(fps - motion.fps) < 1e-9 else motion.sample(video_frame_times(motion.duration, fps), fps=fps)
    if camera is None:
        camera = renderer.camera if renderer is not None and renderer.camera is not None else \
            fit_camera(m.positions, aspect=style.width / style.height)
    enc = dict(ENCODER, **(encoder or {}))
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.stem + ".partial" + path.suffix)
    own = renderer is None
    r = renderer or MotionRenderer(m.skeleton, style, camera)
    if camera is not None:
        r.set_camera(camera)
    r0 = r.render_seconds
    n = 0
    poster_img = None
    try:
        gen = _open_writer(tmp, style.width, style.height, fps, enc)
        try:
            for i, img in enumerate(r.frames(m, progress=progress)):
                if i == poster_frame:
                    poster_img = img
                gen.send(img)
                n += 1
        finally:
            gen.close()
        os.replace(tmp, path)
    finally:
        if own:
            r.close()
        if tmp.exists():
            tmp.unlink()
    poster_path = None
    if poster is not None:
        if poster_img is None:
            raise ValueError(f"poster_frame {poster_frame} is outside the {n}-frame video")
        poster_path = save_png(poster_img, poster)
    secs = time.perf_counter() - t0
    return VideoResult(path, n, fps, n / fps, secs, r.render_seconds - r0, n / secs if secs > 0 else float("inf"),
                       poster_path, enc)


def save_png(image: np.ndarray, path: str | Path) -> Path:
    """Write an ``(H, W, 3|4)`` uint8 image as PNG (deterministic bytes)."""
    import imageio.v3 as iio

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    iio.imwrite(path, np.asarray(image, dtype=np.uint8), extension=".png")
    return path


def render_still(motion: Motion, frame: int = 0, *, style: RenderStyle | None = None,
                 camera: Camera | None = None, path: str | Path | None = None) -> np.ndarray:
    """One frame as an image (optionally saved as PNG)."""
    style = style or RenderStyle()
    if camera is None:
        camera = fit_camera(motion.positions, aspect=style.width / style.height)
    with MotionRenderer(motion.skeleton, style, camera) as r:
        img = r.frame(motion, frame)
    if path is not None:
        save_png(img, path)
    return img


_FILMSTRIP_COLORS = ((0.80, 0.52, 0.30), (0.20, 0.70, 0.72), (0.55, 0.45, 0.80), (0.85, 0.30, 0.35),
                     (0.35, 0.65, 0.30))


def render_filmstrip(motions: Motion | Sequence[Motion], *, n_poses: int = 7, times: Sequence[float] | None = None,
                     layout: str = "overlay", colors: Sequence[Sequence[float]] | None = None,
                     spread: Sequence[float] = (0.0, 0.0, 0.0), fade: float = 0.45,
                     style: RenderStyle | None = None, camera: Camera | None = None,
                     path: str | Path | None = None) -> np.ndarray:
    """A still showing several poses of one or more motions (figures, notebooks).

    Parameters
    ----------
    motions: one motion or a list (e.g. original and edited: the flips paper's Fig. 4
        shows the original in yellow and the edit in turquoise).
    n_poses: poses per motion, evenly spaced over its duration (ignored if ``times``).
    times: seconds at which to show each motion (clipped to each motion's duration).
    layout: ``"overlay"``: all poses of all motions in one scene, each motion in its
        colour, earlier poses lighter (``fade``: 0 = no fading, 1 = earliest white);
        ``"tiles"``: one tile per pose, motions in rows, poses in columns, one
        shared camera.
    spread: extra world offset (metres) added per pose index in the overlay, to
        pull apart poses of a jump that travels little (e.g. ``(0.6, 0, 0)``).
    style: size of the whole image for ``overlay``, of one tile for ``tiles``.
    camera: default fits all shown poses.
    path: also save as PNG.

    Returns the ``(H, W, 3)`` uint8 image.
    """
    ms = [motions] if isinstance(motions, Motion) else list(motions)
    if not ms:
        raise ValueError("render_filmstrip needs at least one motion")
    if layout not in ("overlay", "tiles"):
        raise ValueError(f"layout must be 'overlay' or 'tiles', got {layout!r}")
    style = style or RenderStyle()
    colors = list(colors) if colors is not None else [_FILMSTRIP_COLORS[k % len(_FILMSTRIP_COLORS)]
                                                      for k in range(len(ms))]
    if len(colors) != len(ms):
        raise ValueError(f"{len(ms)} motions but {len(colors)} colours")
    sk = ms[0].skeleton
    for k, m in enumerate(ms[1:], 1):
        if not same_skeleton(m.skeleton, sk):
            raise ValueError(f"motion {k} has a different skeleton from motion 0 (filmstrips draw one character)")
    poses = []  # (motion k, pose index, Motion of one frame)
    for k, m in enumerate(ms):
        ts = np.linspace(0.0, m.duration, n_poses) if times is None else np.clip(np.asarray(times, float), 0,
                                                                                  m.duration)
        for i, t in enumerate(ts):
            one = m.sample([t])
            if layout == "overlay" and np.any(spread):
                one = one.translated(np.asarray(spread, float) * i)
            poses.append((k, i, one))
    n_per = max(i for _, i, _ in poses) + 1
    if camera is None:
        pts = np.concatenate([p.positions[0] for _, _, p in poses])
        aspect = style.width / style.height
        camera = fit_camera(pts, aspect=aspect, margin=0.08 if layout == "overlay" else 0.1)
    if layout == "overlay":
        cols = []
        for k, i, _ in poses:
            base = np.asarray(colors[k], float)
            f = fade * (1.0 - i / max(n_per - 1, 1))
            cols.append(tuple(base + (1.0 - base) * f))
        with MotionRenderer(sk, style, camera, n_characters=len(poses), colors=cols) as r:
            for c, (_, _, p) in enumerate(poses):
                r.set_pose(c, joint_matrices(p)[0])
            img = r.snapshot()
    else:
        rows = []
        with MotionRenderer(sk, style, camera, n_characters=len(ms), colors=colors) as r:
            for k in range(len(ms)):
                for c in range(len(ms)):
                    r.set_visible(c, c == k)
                tiles = [r.frame(p, 0, character=k) for kk, _, p in poses if kk == k]
                rows.append(np.concatenate(tiles, axis=1))
        img = np.concatenate(rows, axis=0)
    if path is not None:
        save_png(img, path)
    return img
