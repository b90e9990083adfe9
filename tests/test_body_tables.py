"""Body segment parameter tables and BodyModel.from_skeleton on a hand-made skeleton."""
import numpy as np
import pytest

from mocomp.body import BodyModel, get_table, mass_fractions, symmetric_groups
from mocomp.body.mapping import OMPH_FRACTION, XYPH_FRACTION
from mocomp.body.tables import DISSERTATION_TABLE_C1, SEGMENT_KINDS, TABLES
from mocomp.body.symmetry import expand_symmetric, reduce_symmetric
from mocomp.core import Skeleton
from mocomp.core.skeleton import EndSite
from mocomp.errors import MotionFormatError


def test_every_table_has_every_segment_kind():
    for t in TABLES.values():
        assert sorted(s.kind for s in t.segments) == sorted(SEGMENT_KINDS)
        for s in t.segments:
            assert 0 < s.mass_fraction < 0.25
            assert 0 <= s.com_fraction <= 1


@pytest.mark.parametrize("key, expected_sum", [("de_leva_male", 1.0), ("de_leva_female", 0.9999), ("dempster", 1.0)])
def test_mass_fractions_sum_to_one(key, expected_sum):
    """Sided fractions (head, 3 trunk parts, 2 x 6 limb segments) sum to 1; de Leva's
    printed female fractions sum to 99.99 % (rounding in the paper), kept as printed."""
    total = sum(mass_fractions(key).values())
    assert total == pytest.approx(expected_sum, abs=1e-9)
    assert abs(total - 1.0) <= 1e-4


@pytest.mark.parametrize("key, trunk", [("de_leva_male", 0.4346), ("de_leva_female", 0.4257), ("dempster", 0.497)])
def test_trunk_split_sums_to_published_whole_trunk(key, trunk):
    """The trunk is split into upper/middle/lower parts (de Leva UPT/MPT/LPT; Dempster
    thorax/abdomen/pelvis), each carried by one spine bone; the parts add up to the
    published whole trunk."""
    t = get_table(key)
    parts = sum(t.row(k).mass_fraction for k in ("upper_trunk", "middle_trunk", "lower_trunk"))
    assert parts == pytest.approx(trunk, abs=1e-9)


def test_trunk_landmark_fractions_follow_de_leva_lengths():
    t = get_table("de_leva_male")
    lpt, mpt, upt = (t.row(k).length_m for k in ("lower_trunk", "middle_trunk", "upper_trunk"))
    assert OMPH_FRACTION == pytest.approx(lpt / (lpt + mpt + upt))
    assert XYPH_FRACTION == pytest.approx((lpt + mpt) / (lpt + mpt + upt))


def test_dissertation_table_c1_initial_column_sums_to_100():
    assert sum(v[2] for v in DISSERTATION_TABLE_C1.values()) == pytest.approx(100.0, abs=0.05)
    # the optimised column is left/right symmetric, as the dissertation says
    for k, v in DISSERTATION_TABLE_C1.items():
        if k.startswith("l") and k not in ("lowerback", "lowerneck"):
            assert v[3] == DISSERTATION_TABLE_C1["r" + k[1:]][3]


def _stick_skeleton(height=1.75):
    """A minimal CMU-named T-pose skeleton (metres), facing +z, left on +x."""
    H = height
    names, parents, offs = [], [], []

    def add(n, p, o):
        names.append(n)
        parents.append(-1 if p is None else names.index(p))
        offs.append(o)

    add("Hips", None, (0, 0.575 * H, 0))
    add("LowerBack", "Hips", (0, 0, 0))
    add("Spine", "LowerBack", (0, 0.12 * H, 0))
    add("Spine1", "Spine", (0, 0.145 * H, 0))
    add("Neck", "Spine1", (0, 0, 0))
    add("Head", "Neck", (0, 0.07 * H, 0))
    for side, sx in (("Left", 1), ("Right", -1)):
        add(f"{side}Arm", "Spine1", (sx * 0.105 * H, -0.02 * H, 0))
        add(f"{side}ForeArm", f"{side}Arm", (sx * 0.172 * H, 0, 0))
        add(f"{side}Hand", f"{side}ForeArm", (sx * 0.15 * H, 0, 0))
        add(f"{side}UpLeg", "Hips", (sx * 0.052 * H, -0.041 * H, 0))
        add(f"{side}Leg", f"{side}UpLeg", (0, -0.2425 * H, 0))
        add(f"{side}Foot", f"{side}Leg", (0, -0.2525 * H, 0))
        add(f"{side}ToeBase", f"{side}Foot", (0, -0.027 * H, 0.08 * H))
    ends = [EndSite(names.index("Head"), (0, 0.09 * H, 0), "Head_end")]
    for side, sx in (("Left", 1), ("Right", -1)):
        ends.append(EndSite(names.index(f"{side}Hand"), (sx * 0.05 * H, 0, 0), f"{side}Hand_end"))
        ends.append(EndSite(names.index(f"{side}ToeBase"), (0, -0.004 * H, 0.04 * H), f"{side}ToeBase_end"))
    return Skeleton(names, parents, offs, end_sites=ends)


@pytest.mark.parametrize("table", sorted(TABLES))
@pytest.mark.parametrize("shape", ["ellipsoid", "cuboid"])
def test_from_skeleton_masses_coms(table, shape):
    sk = _stick_skeleton()
    body = BodyModel.from_skeleton(sk, total_mass=80.0, table=table, shape=shape)
    assert body.total_mass == pytest.approx(80.0, rel=1e-12)
    fr = mass_fractions(table)
    tot = sum(fr.values())
    for name, m in zip(body.segment_names, body.masses):
        assert m == pytest.approx(80.0 * fr[name] / tot)
    # the thigh COM sits at the table fraction from the hip towards the knee
    i = body.segment("thigh_l")
    thigh_len = 0.2425 * 1.75
    assert body.local_coms[i] == pytest.approx([0, -get_table(table).row("thigh").com_fraction * thigh_len, 0], abs=1e-12)
    # inertias: symmetric positive definite, triangle inequality of principal moments
    for I in body.inertias:
        assert np.allclose(I, I.T)
        ev = np.linalg.eigvalsh(I)
        assert ev.min() > 0 and ev[2] <= ev[0] + ev[1] + 1e-15
    # joints carrying nothing are listed by name
    assert set(body.massless_joints) == set(sk.names) - {sk.names[j] for j in body.segment_joint}
    assert "LowerBack" not in body.massless_joints and "Neck" in body.massless_joints


def test_whole_body_com_of_t_pose_is_plausible():
    """Standing T-pose: the COM is about 55-58 % of stature above the soles, centred."""
    sk = _stick_skeleton(1.75)
    body = BodyModel.from_skeleton(sk, 70.0)
    rest = sk.rest_positions()
    com = (body.masses[:, None] * (rest[body.segment_joint] + body.local_coms)).sum(0) / body.total_mass
    sole = rest[:, 1].min() - 0.004 * 1.75
    assert 0.53 < (com[1] - sole) / 1.75 < 0.60
    assert abs(com[0]) < 1e-9


def test_symmetric_groups_pair_left_and_right():
    body = BodyModel.from_skeleton(_stick_skeleton(), 70.0)
    groups = symmetric_groups(body)
    names = body.segment_names
    pairs = [tuple(names[i] for i in g) for g in groups if len(g) == 2]
    assert ("thigh_l", "thigh_r") in pairs and len(pairs) == 6
    assert sorted(i for g in groups for i in g) == list(range(body.n_segments))
    red = reduce_symmetric(groups, body.masses)
    assert np.allclose(expand_symmetric(groups, red), body.masses)


def test_with_masses_recomputes_inertia_and_scaled_to():
    body = BodyModel.from_skeleton(_stick_skeleton(), 70.0)
    same = body.with_masses(body.masses)
    assert np.allclose(same.inertias, body.inertias, rtol=1e-12, atol=0)
    heavier = body.scaled_to(140.0)
    assert heavier.total_mass == pytest.approx(140.0)
    assert np.all(np.linalg.eigvalsh(heavier.inertias) > np.linalg.eigvalsh(body.inertias) * 2 - 1e-15)


def test_bad_inputs_raise_clear_errors():
    sk = _stick_skeleton()
    with pytest.raises(ValueError, match="unknown body segment table"):
        BodyModel.from_skeleton(sk, table="zatsiorsky")
    with pytest.raises(ValueError, match="unknown shape"):
        BodyModel.from_skeleton(sk, shape="sphere")
    with pytest.raises(ValueError, match="total_mass"):
        BodyModel.from_skeleton(sk, total_mass=-1)
    with pytest.raises(ValueError, match="radii of gyration"):
        BodyModel.from_skeleton(sk, table="dempster", shape="gyration")
    with pytest.raises(MotionFormatError, match="no body-segment mapping"):
        BodyModel.from_skeleton(Skeleton(["a", "b"], [-1, 0], [[0, 0, 0], [0, 1, 0]]))
    with pytest.raises(MotionFormatError, match="carrier joint 'Nope'"):
        BodyModel.from_skeleton(sk, mapping={"carriers": {"head": "Nope"}})


def test_mapping_override_moves_a_segment():
    sk = _stick_skeleton()
    base = BodyModel.from_skeleton(sk)
    moved = BodyModel.from_skeleton(sk, mapping={"carriers": {"head": "Neck"}})
    i = base.segment("head")
    assert sk.names[moved.segment_joint[i]] == "Neck"
    assert "Head" in moved.massless_joints
    # same world COM in the rest pose, expressed in another joint's frame
    rest = sk.rest_positions()
    assert np.allclose(rest[moved.segment_joint[i]] + moved.local_coms[i], rest[base.segment_joint[i]] + base.local_coms[i])


def test_gyration_shape_uses_de_leva_radii():
    sk = _stick_skeleton()
    body = BodyModel.from_skeleton(sk, 70.0, shape="gyration")
    i = body.segment("thigh_l")
    L = 0.2425 * 1.75
    # the thigh hangs along -y: longitudinal radius 14.9 %, transverse radii 32.9 %
    assert body.inertias[i][1, 1] == pytest.approx(body.masses[i] * (0.149 * L) ** 2)
    assert body.inertias[i][0, 0] == pytest.approx(body.masses[i] * (0.329 * L) ** 2)


def test_table_c1_comparison_and_plots():
    import matplotlib

    matplotlib.use("Agg")
    from mocomp.body.compare import table_c1_comparison
    from mocomp.plots.dynamics import plot_mass_comparison

    sk = _stick_skeleton()
    df = table_c1_comparison({"de Leva": BodyModel.from_skeleton(sk), "Dempster": BodyModel.from_skeleton(sk, table="dempster")})
    assert df.loc["trunk (incl. clavicles)", "C.1 initial %"] == pytest.approx(42.9)
    assert df.loc["trunk (incl. clavicles)", "de Leva %"] == pytest.approx(43.46)
    assert df.loc["thigh L", "Dempster %"] == pytest.approx(10.0)
    assert df.loc["thigh L", "de Leva - initial"] == pytest.approx(14.16 - 10.2)
    # the groups (without the trunk sub-rows) partition the body
    whole = [g for g in df.index if not g.startswith("  ")]
    assert df.loc[whole, "de Leva %"].sum() == pytest.approx(100.0)
    assert df.loc[whole, "C.1 initial %"].sum() == pytest.approx(100.0, abs=0.05)
    fig = plot_mass_comparison(df)
    assert len(fig.axes[0].patches) == len(df) * 4


def test_which_densities_each_solid_uses():
    """Pinned: the cuboid uses dissertation Table C.1's densities, the ellipsoid Winter's
    Table 4.1 by default (see mocomp.body.tables); both use Table C.1's width/depth ratios;
    densities="table_c1" gives the ellipsoid Table C.1's, with the closed-form effect on
    its long-axis moment (I_long = m/5 (b^2 + c^2) and b c = 3 V / (4 pi a), V = m / rho:
    I_long scales as 1 / rho at fixed mass and length)."""
    from mocomp.body import BodyModel
    from mocomp.body.builder import _kind
    from mocomp.body.tables import ELLIPSOID_DENSITY, SHAPE_DENSITY_RATIO
    from mocomp.synth import synthetic_skeleton

    sk = synthetic_skeleton(1.75)
    kinds = None
    models = {}
    for shape, dens in (("ellipsoid", None), ("cuboid", None), ("ellipsoid", "table_c1"), ("ellipsoid", "winter"),
                        ("cuboid", "winter")):
        b = BodyModel.from_skeleton(sk, 70.0, shape=shape, densities=dens)
        kinds = [_kind(s) for s in b.segment_names]
        models[shape, dens] = b
        np.testing.assert_array_equal(b.geometry.ratios, [SHAPE_DENSITY_RATIO[k][1] for k in kinds])
    c1 = [SHAPE_DENSITY_RATIO[k][0] for k in kinds]
    winter = [ELLIPSOID_DENSITY[k] for k in kinds]
    np.testing.assert_array_equal(models["ellipsoid", None].geometry.densities, winter)
    np.testing.assert_array_equal(models["cuboid", None].geometry.densities, c1)
    np.testing.assert_array_equal(models["ellipsoid", "table_c1"].geometry.densities, c1)
    np.testing.assert_array_equal(models["cuboid", "winter"].geometry.densities, winter)
    assert np.array_equal(models["ellipsoid", "winter"].inertias, models["ellipsoid", None].inertias)
    # the two density sources really differ (thorax 920 vs 1019 kg/m^3), and the moments follow 1/rho
    assert not np.allclose(c1, winter)
    a, b = models["ellipsoid", None], models["ellipsoid", "table_c1"]
    long_a = np.einsum("si,sij,sj->s", a.geometry.axes[:, :, 0], a.inertias, a.geometry.axes[:, :, 0])
    long_b = np.einsum("si,sij,sj->s", b.geometry.axes[:, :, 0], b.inertias, b.geometry.axes[:, :, 0])
    np.testing.assert_allclose(long_b / long_a, np.array(winter) / np.array(c1), rtol=1e-12)
    np.testing.assert_array_equal(a.masses, b.masses)
    assert "Winter" in a.notes[-1] and "Table C.1" in b.notes[-1]
    with pytest.raises(ValueError, match="density source"):
        BodyModel.from_skeleton(sk, 70.0, densities="dg67")
