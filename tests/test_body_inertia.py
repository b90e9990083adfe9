"""Inertia formulas against closed forms and numerical integration; MJCF export."""
import numpy as np
import pytest

from mocomp.body import BodyModel, inertia_for_masses
from mocomp.body.inertia import (cuboid_edges, cuboid_moments, ellipsoid_moments, ellipsoid_semi_axes,
                                 rotate_inertia, segment_axes)
from mocomp.body.mjcf import joint_inertials, mjcf_names, to_mjcf
from test_body_tables import _stick_skeleton


def test_sphere_and_cube_closed_forms():
    assert ellipsoid_moments(2.0, [0.1, 0.1, 0.1]) == pytest.approx([0.4 * 2 * 0.01] * 3)
    assert cuboid_moments(3.0, [0.2, 0.2, 0.2]) == pytest.approx([3.0 * 0.04 / 6] * 3)
    # dissertation eq. 5.3: I = m/12 (w^2 + d^2, l^2 + d^2, l^2 + w^2)
    assert cuboid_moments(12.0, [3.0, 2.0, 1.0]) == pytest.approx([5.0, 10.0, 13.0])
    # thin rod limit of a long ellipsoid: transverse moment -> m a^2 / 5
    assert ellipsoid_moments(1.0, [1.0, 1e-6, 1e-6])[1] == pytest.approx(0.2, rel=1e-9)


def _grid_inertia(inside, half_extent, n=120):
    """Inertia about the origin of a unit-density solid given by a mask function, on a grid."""
    g = (np.arange(n) + 0.5) / n * 2 - 1
    x, y, z = np.meshgrid(g * half_extent[0], g * half_extent[1], g * half_extent[2], indexing="ij")
    m = inside(x, y, z)
    dv = np.prod(2 * np.asarray(half_extent) / n)
    M = m.sum() * dv
    I = np.array([((y**2 + z**2) * m).sum(), ((x**2 + z**2) * m).sum(), ((x**2 + y**2) * m).sum()]) * dv
    return M, I


def test_ellipsoid_against_numerical_integration():
    a, b, c = 0.3, 0.12, 0.07
    M, I = _grid_inertia(lambda x, y, z: (x / a) ** 2 + (y / b) ** 2 + (z / c) ** 2 <= 1, (a, b, c))
    assert M == pytest.approx(4 / 3 * np.pi * a * b * c, rel=2e-3)
    assert ellipsoid_moments(M, [a, b, c]) == pytest.approx(I, rel=5e-3)


def test_dimensions_honour_volume_and_ratio():
    m, L, rho, r = 7.0, 0.42, 1050.0, 0.86
    s = ellipsoid_semi_axes(m, L, rho, r)
    assert s[0] == pytest.approx(L / 2)
    assert s[1] / s[2] == pytest.approx(r)
    assert 4 / 3 * np.pi * np.prod(s) * rho == pytest.approx(m)
    e = cuboid_edges(m, L, rho, r)
    assert e[0] == pytest.approx(L) and e[1] / e[2] == pytest.approx(r) and np.prod(e) * rho == pytest.approx(m)


def test_rotate_inertia_is_similarity_transform():
    from scipy.spatial.transform import Rotation

    R = Rotation.from_rotvec([0.3, -1.1, 0.7]).as_matrix()
    I = rotate_inertia([1.0, 2.0, 3.0], R)
    assert np.allclose(I, R @ np.diag([1.0, 2.0, 3.0]) @ R.T)
    ax = segment_axes(np.array([[0, -1.0, 0], [0, 0, 1.0]]), np.array([0, 0, 1.0]), np.array([0, 1.0, 0]),
                      np.array([False, True]))
    for A in ax:
        assert np.allclose(A.T @ A, np.eye(3))
    assert np.allclose(ax[0][:, 2], [0, 0, 1])  # thigh depth axis = forward
    assert np.allclose(ax[1][:, 2], [0, 1, 0])  # foot depth axis = up


@pytest.mark.parametrize("shape", ["ellipsoid", "cuboid", "gyration"])
def test_inertia_for_masses(shape):
    body = BodyModel.from_skeleton(_stick_skeleton(), 70.0, shape=shape)
    assert np.allclose(inertia_for_masses(body, body.masses), body.inertias, rtol=1e-12, atol=1e-15)
    k = 1.7
    I2 = inertia_for_masses(body, body.masses * k)
    i = body.segment("thigh_l")
    ev1, ev2 = np.linalg.eigvalsh(body.inertias[i]), np.linalg.eigvalsh(I2[i])
    if shape == "gyration":
        assert np.allclose(ev2, k * ev1)
    else:
        # same density and length, so the cross-section area grows with mass: the
        # longitudinal moment (smallest) scales with k^2, transverse ones lie between k and k^2
        assert ev2[0] == pytest.approx(k**2 * ev1[0], rel=1e-9)
        assert np.all(ev2[1:] > k * ev1[1:]) and np.all(ev2[1:] < k**2 * ev1[1:])
    # vectorised over a batch of mass vectors
    batch = np.stack([body.masses, body.masses * k])
    assert np.allclose(inertia_for_masses(body, batch)[1], I2)
    with pytest.raises(ValueError):
        inertia_for_masses(body, -body.masses)


def test_mjcf_loads_in_mujoco_with_same_mass_properties():
    import mujoco

    body = BodyModel.from_skeleton(_stick_skeleton(), 70.0, shape="cuboid")
    model = mujoco.MjModel.from_xml_string(to_mjcf(body))
    sk = body.skeleton
    assert model.nbody == sk.n_joints + 1
    assert model.nq == 7 + 4 * (sk.n_joints - 1) and model.nv == 6 + 3 * (sk.n_joints - 1)
    mass, com, inertia = joint_inertials(body)
    ids = [model.body(n).id for n in mjcf_names(sk)]  # MuJoCo orders bodies depth-first
    assert model.body_subtreemass[ids[0]] == pytest.approx(70.0, rel=1e-9)
    for j, b in enumerate(ids):
        if mass[j] == 0:
            assert model.body_mass[b] <= 1e-9
            continue
        assert model.body_mass[b] == pytest.approx(mass[j], rel=1e-12)
        # MuJoCo diagonalises: its principal moments equal our tensor's eigenvalues
        assert np.allclose(np.sort(model.body_inertia[b]), np.linalg.eigvalsh(inertia[j]), rtol=1e-9, atol=1e-12)
        # body_ipos is the COM in the body frame
        assert np.allclose(model.body_ipos[b], com[j], atol=1e-12)
        assert np.allclose(model.body_pos[b], sk.offsets[j] if j else 0.0, atol=1e-12)


def test_given_inertias_scale_with_mass():
    import dataclasses

    body = BodyModel.from_skeleton(_stick_skeleton(), 70.0)
    given = dataclasses.replace(body, geometry=None, shape="given")
    k = np.linspace(0.5, 2.0, body.n_segments)
    assert np.allclose(inertia_for_masses(given, body.masses * k), body.inertias * k[:, None, None])
    assert np.allclose(given.with_masses(body.masses * k).inertias, body.inertias * k[:, None, None])
