"""Perturbed stimuli of the perception study (study.perturb, study.stimuli, study.spec).

Known answers come from a rigid "tumbling" body whose flight is exact by
construction (constant angular velocity, parabolic COM), from the synthetic
flips of ``mocomp.synth`` and, with real data, from CMU 88_01.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from mocomp.body import BodyModel
from mocomp.core import Motion, Skeleton
from mocomp.core.skeleton import EndSite
from mocomp.dynamics import center_of_mass, momentum
from mocomp.errors import NoFlightPhaseError, PhysicsError, StudyDataError
from study.perturb import rebuild_flight, signed_level, time_warp
from study.spec import load_spec, parse_spec
from study.stimuli import make_stimulus, measure_stimulus, BaseMotion

ROOT = Path(__file__).resolve().parents[1]
G = 9.81


# ---------------------------------------------------------------- toy flight
def stick_skeleton() -> Skeleton:
    names = ["Hips", "Spine", "Head", "LeftUpLeg", "LeftLeg", "RightUpLeg", "RightLeg", "LeftArm", "RightArm"]
    parents = [-1, 0, 1, 0, 3, 0, 5, 1, 1]
    offsets = [[0, 0, 0], [0, 0.25, 0], [0, 0.30, 0], [0.1, 0, 0], [0, -0.45, 0], [-0.1, 0, 0], [0, -0.45, 0],
               [0.18, 0.22, 0], [-0.18, 0.22, 0]]
    ends = [EndSite(2, [0, 0.2, 0], "Head_end"), EndSite(4, [0, -0.45, 0.05], "LeftLeg_end"),
            EndSite(6, [0, -0.45, 0.05], "RightLeg_end"), EndSite(7, [0.0, -0.5, 0], "LeftArm_end"),
            EndSite(8, [0.0, -0.5, 0], "RightArm_end")]
    return Skeleton(names, parents, offsets, end_sites=ends)


def stick_body(sk: Skeleton) -> BodyModel:
    """Rods from each joint towards its child/end site (explicit, independent of mapping tables)."""
    segs = [("trunk", 0, 30.0, [0, 0.12, 0], 0.25), ("chest", 1, 15.0, [0, 0.15, 0], 0.3), ("head", 2, 5.0, [0, 0.1, 0], 0.2),
            ("thigh_l", 3, 7.0, [0, -0.22, 0], 0.45), ("shank_l", 4, 4.0, [0, -0.22, 0], 0.45),
            ("thigh_r", 5, 7.0, [0, -0.22, 0], 0.45), ("shank_r", 6, 4.0, [0, -0.22, 0], 0.45),
            ("arm_l", 7, 3.0, [0, -0.25, 0], 0.5), ("arm_r", 8, 3.0, [0, -0.25, 0], 0.5)]
    I = []
    for _, _, m, _, L in segs:  # rod along y, radius 0.05 m
        r = 0.05
        I.append(np.diag([m * L * L / 12 + m * r * r / 4, m * r * r / 2, m * L * L / 12 + m * r * r / 4]))
    return BodyModel(sk, tuple(s[0] for s in segs), [s[1] for s in segs], [s[2] for s in segs],
                     [s[3] for s in segs], np.array(I), table="test rods")


def tumbling_flip(fps=100.0, n_stand=20, T=0.6, turns=1.0, vx=-0.6, n_land=25):
    """Stand still, tumble rigidly through ``turns`` somersaults about z on an exact parabola, land still.

    Returns (motion, body, flight) with the flight as a half-open frame range.
    """
    sk = stick_skeleton()
    body = stick_body(sk)
    nf = int(round(T * fps))
    a, b = n_stand, n_stand + nf + 1  # airborne frames a..b-1, t_b - t_a = T
    n = b + n_land
    J = sk.n_joints
    rot = np.zeros((n, J, 4))
    rot[..., 3] = 1.0
    # a fixed crouched pose in the x-y plane (so z, the spin axis, stays a principal axis)
    rot[:, 3] = rot[:, 5] = Rotation.from_euler("z", -60, degrees=True).as_quat()
    rot[:, 4] = rot[:, 6] = Rotation.from_euler("z", 90, degrees=True).as_quat()
    rest = Motion(sk, fps, np.zeros((1, 3)), rot[:1])
    c_local = center_of_mass(body, rest)[0]  # COM in the root frame (root at origin, identity)
    t = np.arange(n) / fps
    u = np.clip(t - a / fps, 0.0, T)
    angle = 2 * np.pi * turns * u / T
    q = Rotation.from_rotvec(np.outer(angle, [0, 0, 1.0]))
    rot[:, 0] = q.as_quat()
    p0 = np.array([0.0, 1.0, 0.0])
    v0 = np.array([vx, 0.5 * G * T, 0.0])
    com = p0 + np.outer(u, v0) - 0.5 * G * (u ** 2)[:, None] * np.array([0, 1.0, 0])
    root = com - q.apply(c_local)
    return Motion(sk, fps, root, rot), body, (a, b)


@pytest.fixture(scope="module")
def toy():
    m, body, flight = tumbling_flip()
    com = lambda mm: center_of_mass(body, mm)  # noqa: E731
    control = rebuild_flight(m, flight, com, kind="none")
    return m, body, flight, com, control


def test_toy_is_ballistic(toy):
    m, body, (a, b), _, control = toy
    L = momentum(body, m).angular[a + 1:b - 1]
    assert np.allclose(L, L.mean(0), rtol=0, atol=1e-6 * np.abs(L).max())
    # the control is the capture itself; the ballistic re-fit of an exact flight is the flight itself
    assert np.array_equal(control.motion.root_positions, m.root_positions)
    assert control.capture_deviation < 1e-9
    com = lambda mm: center_of_mass(body, mm)  # noqa: E731
    ballistic = rebuild_flight(m, (a, b), com, kind="none", com_mode="ballistic")
    assert ballistic.root_offset.max() < 1e-9


@pytest.mark.parametrize("kind,e", [("am_abrupt", 0.37), ("am_smooth", -0.25), ("takeoff", 0.2)])
def test_com_modes_agree_on_exact_flights(toy, kind, e):
    m, body, flight, com, _ = toy
    r1 = rebuild_flight(m, flight, com, kind=kind, error=e, com_mode="capture")
    r2 = rebuild_flight(m, flight, com, kind=kind, error=e, com_mode="ballistic")
    # equal up to the linear interpolation of the root between frames (retimed flights
    # sample between frames; 'ballistic' puts the COM exactly on the parabola)
    tol = 1e-9 if kind == "takeoff" else 1e-3
    assert np.allclose(r1.motion.root_positions, r2.motion.root_positions, atol=tol)


def test_capture_mode_keeps_the_capture_deviation():
    """A non-ballistic wobble of the captured COM stays in every stimulus (retimed), and
    the perturbation adds exactly the change of the ideal flight."""
    m, body, flight = tumbling_flip()
    a, b = flight
    t = np.arange(m.n_frames) / m.fps
    u = np.clip(t - a / m.fps, 0, (b - 1 - a) / m.fps)
    wobble = 0.03 * np.sin(np.pi * u / u.max())[:, None] * np.array([1.0, 1.0, 0.0])
    mw = m.replace(root_positions=m.root_positions + wobble)
    com = lambda mm: center_of_mass(body, mm)  # noqa: E731
    ctl = rebuild_flight(mw, flight, com, kind="none")
    assert np.array_equal(ctl.motion.root_positions, mw.root_positions)
    assert ctl.capture_deviation == pytest.approx(0.03 * np.sqrt(2), rel=1e-3)
    r = rebuild_flight(mw, flight, com, kind="takeoff", error=0.3)
    rn = rebuild_flight(m, flight, com, kind="takeoff", error=0.3)
    assert np.allclose(r.motion.root_positions - rn.motion.root_positions, wobble, atol=1e-9)
    bal = rebuild_flight(mw, flight, com, kind="none", com_mode="ballistic")
    assert np.allclose(bal.motion.root_positions, m.root_positions, atol=1e-6)


@pytest.mark.parametrize("kind", ["am_abrupt", "am_smooth"])
@pytest.mark.parametrize("e", [-0.5, -0.17, 0.25, 0.5])
def test_warp_consumes_the_whole_flight(kind, e):
    T = 0.7
    w = time_warp(kind, e, T, 0.5)
    assert w.sigma(w.new_T) == pytest.approx(T, rel=1e-12)
    u = np.linspace(0, w.new_T, 2001)
    # rate is the derivative of sigma
    assert np.allclose(np.gradient(w.sigma(u), u)[5:-5], w.rate(u)[5:-5], atol=1e-6 if kind == "am_smooth" else 1)
    assert w.rate(np.array([w.new_T * 0.999]))[0] == pytest.approx(1 + e, abs=2e-3)
    assert w.rate(np.array([0.0]))[0] == pytest.approx(1.0)
    if kind == "am_abrupt":
        assert w.rate(np.array([0.49 * T]))[0] == 1.0
        assert w.new_T == pytest.approx(0.5 * T + 0.5 * T / (1 + e))
    else:
        assert w.new_T == pytest.approx(T / (1 + e / 2))


@pytest.mark.parametrize("kind", ["am_abrupt", "am_smooth"])
@pytest.mark.parametrize("direction,level", [("increase", 0.17), ("increase", 0.5), ("decrease", 0.25),
                                             ("decrease", 0.5)])
def test_angular_momentum_error_known_answer(toy, kind, direction, level):
    m, body, flight, com, control = toy
    e = signed_level(direction, level)
    rb = rebuild_flight(m, flight, com, kind=kind, error=e)
    meas = measure_stimulus(rb, control, body)
    # central differences see a faster rotation slightly slower (sin(w dt)/(w dt); the
    # numerical-derivative error of flips paper sec. 5.1): 0.3 points at +50 % here
    assert meas["achieved_error"] == pytest.approx(100 * level, abs=0.5)
    assert meas["L_direction_change_deg"] < 0.5
    # |L| per frame follows the retiming rate (flips paper eq. 5.8: v_new = n v)
    fa, fb = rb.flight
    L = np.linalg.norm(momentum(body, rb.motion).angular, axis=1)
    L0 = np.linalg.norm(momentum(body, m).angular[flight[0] + 2])
    inner = np.arange(fa + 2, fb - 2)
    if kind == "am_abrupt":
        inner = inner[np.abs((inner - fa) / m.fps - rb.warp.switch_u) > 2 / m.fps]
    assert np.allclose(L[inner] / L0, rb.rate[inner], atol=0.01)
    # plausibility: same take-off (frames before take-off untouched), lands on its feet
    assert np.array_equal(rb.motion.root_positions[:flight[0]], m.root_positions[:flight[0]])
    assert np.allclose(rb.motion.rotations[-5:], m.rotations[-5:], atol=1e-9)
    C = center_of_mass(body, rb.motion)
    C0 = center_of_mass(body, m)
    assert C[-1, 1] == pytest.approx(C0[-1, 1], abs=1e-9)
    # continuous: no position jump larger than the flight's own speed allows
    step = np.linalg.norm(np.diff(rb.motion.positions, axis=0), axis=2).max()
    step0 = np.linalg.norm(np.diff(m.positions, axis=0), axis=2).max()
    assert step < 1.7 * step0
    # the flight COM is a parabola under g with the take-off angle unchanged
    t = np.arange(fb - fa) / m.fps
    coef = np.polyfit(t, C[fa:fb, 1], 2)
    assert -2 * coef[0] == pytest.approx(G, rel=2e-3)  # root interpolated between frames: ~0.1 %
    rbb = rebuild_flight(m, flight, com, kind=kind, error=e, com_mode="ballistic")
    Cb = center_of_mass(body, rbb.motion)
    assert -2 * np.polyfit(t, Cb[fa:fb, 1], 2)[0] == pytest.approx(G, rel=1e-9)
    assert meas["takeoff_angle_change_deg"] == pytest.approx(0.0, abs=0.01)
    assert meas["flight_s"] == pytest.approx(rb.warp.new_T)
    # the velocity jump the perturbation adds at take-off: the whole take-off velocity is scaled,
    # v = kappa v0, and the motion shows exactly that jump against the control (same ground phase)
    v, v0 = rb.velocity, control.velocity
    assert meas["takeoff_dv_added_ms"] == pytest.approx(np.linalg.norm(v - v0))
    kappa = v[1] / v0[1]
    assert np.allclose(v, kappa * v0) and (kappa < 1) == (e > 0)  # faster rotation, shorter and lower flight
    a = flight[0]
    jump = (C[fa + 1] - C[fa]) * m.fps - (C0[a + 1] - C0[a]) * m.fps
    assert np.linalg.norm(jump - (v - v0)) < 0.05
    land = (v - G * rb.warp.new_T * np.array([0, 1.0, 0])) - (v0 - G * rb.warp.T * np.array([0, 1.0, 0]))
    assert meas["landing_dv_added_ms"] == pytest.approx(np.linalg.norm(land))
    assert meas["landing_rate"] == pytest.approx(1 + e, abs=0.02 * abs(e) + 1e-9)


@pytest.mark.parametrize("direction,level", [("increase", 0.1), ("increase", 0.4), ("decrease", 0.3)])
def test_takeoff_angle_error_known_answer(toy, direction, level):
    m, body, flight, com, control = toy
    e = signed_level(direction, level)
    rb = rebuild_flight(m, flight, com, kind="takeoff", error=e)
    meas = measure_stimulus(rb, control, body)
    assert meas["achieved_error"] == pytest.approx(100 * level, abs=1e-3)
    assert meas["L_error_pct"] == pytest.approx(0.0, abs=0.05)
    assert rb.flight == control.flight and rb.warp.new_T == control.warp.new_T
    # vertical velocity unchanged, horizontal along the jump direction scaled by 1 + e
    v0 = control.velocity
    assert rb.velocity[1] == pytest.approx(v0[1])
    assert rb.velocity[0] == pytest.approx(v0[0] * (1 + e))
    expect = np.degrees(np.arctan2(v0[1], abs(v0[0]) * (1 + e))) - np.degrees(np.arctan2(v0[1], abs(v0[0])))
    assert meas["takeoff_angle_change_deg"] == pytest.approx(expect, abs=1e-6)
    assert meas["landing_shift_m"] == pytest.approx(abs(e * v0[0]) * rb.warp.T, rel=1e-9)
    # the added velocity jump is the horizontal change e v_h, at take-off and at touchdown alike
    assert meas["takeoff_dv_added_ms"] == pytest.approx(abs(e * v0[0]), rel=1e-9)
    assert meas["landing_dv_added_ms"] == pytest.approx(abs(e * v0[0]), rel=1e-9)
    assert meas["landing_rate"] == 1.0


def test_takeoff_needs_horizontal_travel():
    m, body, flight = tumbling_flip(vx=0.0)
    com = lambda mm: center_of_mass(body, mm)  # noqa: E731
    with pytest.raises(PhysicsError, match="horizontally"):
        rebuild_flight(m, flight, com, kind="takeoff", error=0.2)
    # angular-momentum errors still work on a vertical jump
    rebuild_flight(m, flight, com, kind="am_smooth", error=0.2)


def test_bad_requests(toy):
    m, body, flight, com, _ = toy
    with pytest.raises(NoFlightPhaseError):
        rebuild_flight(m, (0, flight[1]), com, kind="none")
    with pytest.raises(NoFlightPhaseError):
        rebuild_flight(m, (flight[0], m.n_frames), com, kind="none")
    with pytest.raises(PhysicsError):
        rebuild_flight(m, flight, com, kind="am_smooth", error=-1.0)
    with pytest.raises(ValueError, match="unknown perturbation"):
        rebuild_flight(m, flight, com, kind="twist", error=0.1)
    with pytest.raises(ValueError):
        signed_level("sideways", 0.1)


def test_make_stimulus_ids_and_percent(toy):
    m, body, flight, _, _ = toy
    base = BaseMotion("toy", "test", m, body, flight)
    s = make_stimulus(base, "am_abrupt", "decrease", 37)
    assert s.stimulus_id == "toy__am_abrupt_decrease_37"
    assert s.nominal_level == 37.0
    assert s.measures["achieved_error"] == pytest.approx(37, abs=0.5)
    assert s.measures["achieved_signed_pct"] == pytest.approx(-37, abs=0.5)
    c = make_stimulus(base, "none", "none", 0)
    assert c.stimulus_id == "toy__none" and abs(c.measures["achieved_error"]) < 0.05


# -------------------------------------------------------------------- specs
def test_paper_spec_design():
    spec = load_spec(ROOT / "stimuli" / "paper_table2.toml")
    d = spec.design()
    assert len(spec.bases) == 3 and len(d) == 3 * 21
    per = {(p, dd) for _, p, dd, _ in d}
    assert per == {("none", "none"), ("am_abrupt", "increase"), ("am_abrupt", "decrease"), ("am_smooth", "increase"),
                   ("am_smooth", "decrease"), ("takeoff", "increase")}
    assert sorted({lv for _, p, _, lv in d if p.startswith("am")}) == [17, 25, 37, 50]
    assert sorted({lv for _, p, _, lv in d if p == "takeoff"}) == [10, 20, 30, 40]
    assert spec.render.width == 640 and spec.render.height == 480 and spec.render.fps == 30


@pytest.mark.parametrize("patch,field", [
    ({"render": {"widht": 640}}, "render"),
    ({"render": {"width": 641}}, "render.width"),
    ({"condition": [{"perturbation": "am_smooth", "levels": [0]}]}, "condition[0].levels"),
    ({"condition": [{"perturbation": "spin", "levels": [10]}]}, "condition[0].perturbation"),
    ({"condition": [{"perturbation": "am_smooth", "directions": ["up"], "levels": [10]}]}, "condition[0].directions"),
    ({"base": [{"id": "a", "source": "example:x"}, {"id": "a", "source": "example:y"}]}, "base[1].id"),
    ({"base": [{"id": "a__b", "source": "example:x"}]}, "base[0].id"),
    ({"base": [{"id": "a", "source": "http://x"}]}, "base[0].source"),
    ({"base": []}, "base"),
])
def test_spec_errors_name_the_field(tmp_path, patch, field):
    data = {"base": [{"id": "a", "source": "example:backflip"}],
            "condition": [{"perturbation": "am_abrupt", "directions": ["increase"], "levels": [17]}]}
    data.update(patch)
    p = tmp_path / "s.json"
    p.write_text(json.dumps(data))
    with pytest.raises(StudyDataError) as ei:
        load_spec(p)
    assert f"[{field}]" in str(ei.value) and str(p) in str(ei.value)


def test_spec_file_errors(tmp_path):
    with pytest.raises(FileNotFoundError):
        load_spec(tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[render\nwidth=3")
    with pytest.raises(StudyDataError, match="invalid TOML"):
        load_spec(bad)
    (tmp_path / "x.yaml").write_text("a: 1")
    with pytest.raises(StudyDataError, match="unknown specification format"):
        load_spec(tmp_path / "x.yaml")


# --------------------------------------------------- synthetic and real flips
def _have_examples(*names):
    from mocomp import datasets

    return all(n in datasets.examples() for n in names)


SYNTH = ["backflip", "frontflip"]


@pytest.mark.skipif(not _have_examples(*SYNTH), reason="mocomp.synth flips not available")
@pytest.mark.parametrize("name", SYNTH)
def test_synthetic_flips_achieved_matches_nominal(name):
    from study.stimuli import build_stimuli

    spec = parse_spec({"base": [{"id": name, "source": f"example:{name}"}],
                       "condition": [{"perturbation": "am_abrupt", "directions": ["increase", "decrease"],
                                      "levels": [17, 50]},
                                     {"perturbation": "am_smooth", "directions": ["increase", "decrease"],
                                      "levels": [25, 37]},
                                     {"perturbation": "takeoff", "directions": ["increase"], "levels": [20]}],
                       "flight": {"am_mode": "retime"}})
    built = build_stimuli(spec)
    ctl = built.stimuli[0]
    assert ctl.perturbation == "none" and abs(ctl.measures["achieved_error"]) < 0.5
    # exact synthetic flight: its COM is the ballistic parabola
    assert ctl.measures["com_capture_dev_m"] < 0.005
    for s in built.stimuli[1:]:
        assert s.measures["achieved_error"] == pytest.approx(s.nominal_level, abs=1.0), s.stimulus_id
        if s.perturbation.startswith("am_"):
            assert s.measures["L_direction_change_deg"] < 2.0
            assert abs(s.measures["takeoff_angle_change_deg"]) < 0.02  # root interpolated between frames
    # same take-off position: every stimulus starts with the control's frames
    for s in built.stimuli:
        a = s.rebuild.flight[0]
        assert np.allclose(s.motion.positions[:a], ctl.motion.positions[:a], atol=1e-9)
    # normalised: L along +z, take-off COM above the origin
    base = built.bases[0]
    L = momentum(base.body, base.motion).angular[base.flight[0] + 1:base.flight[1] - 1].mean(0)
    assert L[2] > 0 and abs(L[0]) < 1e-3 * abs(L[2])
    C = center_of_mass(base.body, base.motion)[base.flight[0]]
    assert abs(C[0]) < 1e-9 and abs(C[2]) < 1e-9


@pytest.mark.realdata
def test_real_backflip_stimuli(real_data_dir):
    from study.stimuli import build_stimuli

    spec = parse_spec({"base": [{"id": "cmu", "source": "clip:cmu_88_01_backflip"}],
                       "condition": [{"perturbation": "am_abrupt", "directions": ["increase", "decrease"],
                                      "levels": [25, 50]},
                                     {"perturbation": "am_smooth", "directions": ["increase", "decrease"],
                                      "levels": [17, 50]},
                                     {"perturbation": "takeoff", "directions": ["increase"], "levels": [30]}]})
    built = build_stimuli(spec)
    info = built.base_info["cmu"]
    # the flight found by contact detection is the one in the data MANIFEST (frames ~46-80 of the 60 Hz clip)
    assert 0.45 < info["flight_s"] < 0.62
    for s in built.stimuli[1:]:
        # capture noise in |L| cancels in the per-original-time ratio: within 2 points
        assert s.measures["achieved_error"] == pytest.approx(s.nominal_level, abs=2.0), s.stimulus_id
    ctl = built.stimuli[0]
    # the control is the (corrected) capture: made ballistic before perturbing (issue 19 item 2):
    # 88_01 fits g = 12.4 m/s^2 at 60 Hz; its COM moved by 0.16 m onto a 9.81 parabola
    assert ctl.rebuild.root_offset.max() == 0.0
    assert ctl.measures["com_capture_dev_m"] < 1e-6
    assert 0.1 < info["ballistic_correction_m"] < 0.2 and info["g_fit_before_correction"] > 11.0


# ------------------------------------------------------- issue 19: rotation-only stimuli and cues
@pytest.mark.parametrize("kind,e", [("am_abrupt", 0.5), ("am_abrupt", -0.25), ("am_smooth", 0.5), ("am_smooth", -0.5)])
def test_rotation_only_toy_known_answer(toy, kind, e):
    """Rigid tumbler (constant inertia, constant L): the orientation's rate is s r(u) with
    s = 1 / (phi + (1 - phi)(1 + e)) (abrupt, phi = 0.5) or 1 / (1 + e/2) (smooth), so the total
    turn is the base's; COM, flight frames and ground frames are the base's exactly."""
    from mocomp.dynamics import composite_inertia
    from study.perturb import rotate_flight

    m, body, flight, com, control = toy
    rb = rotate_flight(m, flight, com, lambda mm: momentum(body, mm).angular,
                       lambda mm: composite_inertia(body, mm), kind=kind, error=e)
    s_expect = 1 / (0.5 + 0.5 * (1 + e)) if kind == "am_abrupt" else 1 / (1 + e / 2)
    assert rb.rotation_scale == pytest.approx(s_expect, rel=2e-3)  # trapezoid over a 1-frame step
    a, b = flight
    assert rb.motion.n_frames == m.n_frames and rb.flight == flight
    assert np.abs(center_of_mass(body, rb.motion) - center_of_mass(body, m)).max() < 1e-9
    assert np.array_equal(rb.motion.rotations[:a], m.rotations[:a])
    assert np.allclose(rb.motion.rotations[b - 1:], m.rotations[b - 1:], atol=1e-12)  # lands in the base's pose
    meas = measure_stimulus(rb, control, body)
    assert meas["L_error_pct"] == pytest.approx(100 * e, abs=1.0)
    assert meas["flight_s"] == pytest.approx(control.warp.T, abs=1e-12)
    assert meas["cue_takeoff_rotation_ratio"] == pytest.approx(s_expect, abs=0.02)
    assert meas["cue_landing_rotation_ratio"] == pytest.approx(s_expect * (1 + e), abs=0.03)


def _spec(conditions, **flight):
    return parse_spec({"base": [{"id": "bf", "source": "example:backflip"}], "condition": conditions, "flight": flight})


@pytest.mark.skipif(not _have_examples("backflip"), reason="mocomp.synth flips not available")
def test_rotation_only_backflip_acceptance():
    """Issue 19 acceptance on the synthetic back flip: COM within 1 mm, flight duration exact,
    |L| within 1 point of nominal; the cues are measured on the frames (audit + dynamics)."""
    from study.stimuli import build_stimuli

    built = build_stimuli(_spec([{"perturbation": "am_abrupt", "directions": ["increase", "decrease"], "levels": [50]},
                                 {"perturbation": "am_smooth", "directions": ["increase", "decrease"], "levels": [25]}]))
    base = built.bases[0]
    assert built.base_info["bf"]["ballistic_correction_m"] < 1e-6  # exact flight: nothing to correct
    C0 = center_of_mass(base.body, base.motion)
    ctl = built.stimuli[0]
    for s in built.stimuli[1:]:
        assert s.measures["am_mode"] == "rotation"
        assert s.motion.n_frames == base.motion.n_frames and s.rebuild.flight == base.flight
        assert np.linalg.norm(center_of_mass(base.body, s.motion) - C0, axis=1).max() < 1e-3
        assert s.measures["cue_com_change_m"] < 1e-3
        assert s.measures["flight_s"] == pytest.approx(ctl.measures["flight_s"], abs=1e-12)  # same frames
        assert s.measures["achieved_error"] == pytest.approx(s.nominal_level, abs=1.0), s.stimulus_id
        # the audit sees the same jump: apex, take-off and landing COM jumps as the control's
        assert s.measures["cue_apex_m"] == pytest.approx(ctl.measures["cue_apex_m"], abs=0.03)
        assert s.measures["cue_takeoff_jump_ms"] == pytest.approx(ctl.measures["cue_takeoff_jump_ms"], abs=0.05)
        assert abs(s.measures["cue_flight_change_s"]) <= 1.5 / base.motion.fps  # contact detector: <= 1 frame
        # the rotation-speed change where the flight meets the ground, measured: s and s (1 + e)
        e = s.rebuild.error
        assert s.measures["cue_landing_rotation_ratio"] / s.measures["cue_takeoff_rotation_ratio"] == \
            pytest.approx(1 + e, abs=0.05)
        a, b = base.flight
        assert np.array_equal(s.motion.root_positions[:a], base.motion.root_positions[:a])
        assert np.allclose(s.motion.positions[b:], base.motion.positions[b:], atol=1e-9)


@pytest.mark.skipif(not _have_examples("backflip"), reason="mocomp.synth flips not available")
def test_retime_mode_confounds_are_measured():
    """The paper-literal mode stays selectable; its confounds show in the measured cues
    (issue 19: -50 % abrupt, apex 0.47 -> 1.14 m and flight 0.66 -> 0.99 s on the synthetic flip)."""
    from study.stimuli import build_stimuli

    built = build_stimuli(_spec([{"perturbation": "am_abrupt", "directions": ["decrease"], "levels": [50]}],
                                am_mode="retime"))
    ctl, s = built.stimuli
    assert s.measures["am_mode"] == "retime"
    assert s.measures["achieved_error"] == pytest.approx(50, abs=1.0)
    assert s.measures["cue_flight_change_s"] > 0.3 and s.measures["cue_apex_change_m"] > 0.5
    assert s.measures["cue_takeoff_jump_ms"] > ctl.measures["cue_takeoff_jump_ms"] + 1.0
    assert s.measures["cue_landing_rotation_ratio"] == pytest.approx(0.5, abs=0.05)


@pytest.mark.skipif(not _have_examples("backflip"), reason="mocomp.synth flips not available")
def test_takeoff_levels_velocity_and_angle_are_measured():
    from study.stimuli import build_stimuli

    vel = build_stimuli(_spec([{"perturbation": "takeoff", "directions": ["increase"], "levels": [40]}]))
    s = vel.stimuli[1]
    assert s.measures["level_unit"] == "percent"
    assert s.measures["achieved_error"] == pytest.approx(40, abs=0.5)  # from the motion's COM, not the plan
    # 40 % of the horizontal speed is only a few degrees of take-off angle (the audit's, from vertical)
    assert 2.0 < s.measures["cue_takeoff_angle_change_deg"] < 9.0
    ang = build_stimuli(_spec([{"perturbation": "takeoff", "directions": ["increase", "decrease"], "levels": [5]}],
                              takeoff_levels="angle"))
    for s in ang.stimuli[1:]:
        assert s.measures["level_unit"] == "deg"
        assert s.measures["achieved_error"] == pytest.approx(s.measures["cue_takeoff_angle_change_deg"]
                                                             * (1 if s.direction == "increase" else -1))
        assert s.measures["achieved_error"] == pytest.approx(5.0, abs=0.75)
        assert abs(s.measures["imposed_velocity_change_pct"]) > 20  # 5 deg needs a large speed change
    with pytest.raises(StudyDataError, match="takeoff_levels"):
        parse_spec({"base": [{"id": "b", "source": "example:backflip"}], "flight": {"takeoff_levels": "speed"}})
    with pytest.raises(StudyDataError, match="degrees"):
        _spec([{"perturbation": "takeoff", "levels": [60]}], takeoff_levels="angle")
    with pytest.raises(StudyDataError, match="am_mode"):
        _spec([], am_mode="paper")


def test_rotation_mode_is_the_default_and_paper_spec_is_literal():
    assert parse_spec({"base": [{"id": "b", "source": "example:backflip"}]}).am_mode == "rotation"
    paper = load_spec(ROOT / "stimuli" / "paper_table2.toml")
    assert paper.am_mode == "retime" and paper.base_correction == "ballistic"
    real = load_spec(ROOT / "stimuli" / "real_flips.toml")
    assert real.am_mode == "rotation"
    assert {b.source for b in real.bases} >= {"clip:cmu_88_01_backflip", "clip:cmu_88_05_cartwheel_backflip",
                                              "clip:cmu_90_08_sideflip"}


@pytest.mark.realdata
def test_every_real_flip_is_made_ballistic_and_perturbed(real_data_dir):
    """Issue 19 items 2-3: every real flip of the data folder, corrected to g = 9.81 (size recorded,
    the audit's ballistic check passes on the flight), rotation-only stimuli within 1 point."""
    from mocomp.audit import audit
    from study.stimuli import build_stimuli

    spec = load_spec(ROOT / "stimuli" / "real_flips.toml")
    spec = parse_spec({**spec.raw, "base": [b for b in spec.raw["base"] if b["source"].startswith("clip:")],
                       "condition": [{"perturbation": "am_abrupt", "directions": ["increase"], "levels": [50]},
                                     {"perturbation": "am_smooth", "directions": ["decrease"], "levels": [25]}]})
    built = build_stimuli(spec)
    assert len(built.bases) == 3 and not built.skipped_bases
    for base in built.bases:
        info = built.base_info[base.id]
        assert 0.01 < info["ballistic_correction_m"] < spec.max_correction_m, base.id
        rep = audit(base.motion, base.body)
        a, b = base.flight
        grav = [f for f in rep.by_check("gravity") if f.frames[0] < b and f.frames[1] > a]
        assert not grav, (base.id, [f.line() for f in grav])
        main = [f for f in rep.flights if f.fit is not None and f.frames[0] < b and f.frames[1] > a]
        assert main and abs(main[0].fit.g - 9.81) < 0.3, base.id
    for s in built.stimuli:
        if s.perturbation == "none":
            continue
        base = next(bm for bm in built.bases if bm.id == s.base_clip)
        assert s.measures["achieved_error"] == pytest.approx(s.nominal_level, abs=1.0), s.stimulus_id
        C0 = center_of_mass(base.body, base.motion)
        assert np.linalg.norm(center_of_mass(base.body, s.motion) - C0, axis=1).max() < 1e-3
        assert s.measures["flight_s"] == pytest.approx(base.info["flight_s"], abs=1e-12)


@pytest.mark.realdata
def test_base_needing_a_large_correction_is_refused(real_data_dir):
    from study.stimuli import build_stimuli

    spec = parse_spec({"base": [{"id": "cmu", "source": "clip:cmu_88_01_backflip"}],
                       "flight": {"max_correction_m": 0.05}})
    with pytest.raises(StudyDataError, match=r"moves its COM by 0\.1\d\d m"):
        build_stimuli(spec)
    # the default bound (0.2 m) refuses a clip read at its header's wrong 120 Hz (g fits 43-49 m/s^2;
    # the correction would be 0.27-0.48 m) and accepts it at the real 60 Hz (0.036-0.164 m)
    wrong = parse_spec({"base": [{"id": "side", "source": "clip:cmu_90_08_sideflip", "fps": 120}]})
    with pytest.raises(StudyDataError, match=r"base 'side'.*0\.2\d\d m.*max_correction_m"):
        build_stimuli(wrong)
