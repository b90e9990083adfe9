"""BodyModel.from_skeleton builds a table model once per skeleton object and arguments (a pure
function of immutable inputs), and never hands one skeleton's model to another."""
import numpy as np
import pytest

from mocomp import datasets
from mocomp.body import BodyModel
from mocomp.body import model as model_mod
from mocomp.core.skeleton import Skeleton


def test_same_skeleton_and_arguments_give_the_same_model():
    sk = datasets.load("backflip").skeleton
    a = BodyModel.from_skeleton(sk, total_mass=70.0)
    assert BodyModel.from_skeleton(sk, total_mass=70.0) is a
    b = BodyModel.from_skeleton(sk, total_mass=80.0)
    c = BodyModel.from_skeleton(sk, total_mass=70.0, shape="cuboid")
    assert b is not a and c is not a
    np.testing.assert_allclose(b.masses, a.masses * 80.0 / 70.0, rtol=1e-12)
    with pytest.raises(ValueError):                       # the cached model's arrays are read-only
        a.geometry.lengths[0] = 1.0


def test_an_equal_skeleton_object_gets_its_own_model():
    sk = datasets.load("backflip").skeleton
    a = BodyModel.from_skeleton(sk)
    twin = Skeleton(names=sk.names, parents=sk.parents.copy(), offsets=sk.offsets.copy(), channels=sk.channels,
                    end_sites=sk.end_sites)
    b = BodyModel.from_skeleton(twin)
    assert b is not a and b.skeleton is twin and a.skeleton is sk
    np.testing.assert_array_equal(b.masses, a.masses)
    np.testing.assert_array_equal(b.inertias, a.inertias)


def test_the_cache_is_bounded_and_bad_arguments_still_raise():
    sk = datasets.load("backflip").skeleton
    for k in range(model_mod._TABLE_BODIES_MAX + 5):
        BodyModel.from_skeleton(sk, total_mass=50.0 + k)
    assert len(model_mod._TABLE_BODIES) <= model_mod._TABLE_BODIES_MAX
    with pytest.raises(ValueError, match="total_mass"):
        BodyModel.from_skeleton(sk, total_mass=-1.0)
    with pytest.raises(ValueError, match="total_mass"):
        BodyModel.from_skeleton(sk, total_mass=-1.0)
