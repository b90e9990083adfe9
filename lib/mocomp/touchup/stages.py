"""Ground and flight stages of a motion (touch-up paper, Shin et al. 2003, sec. 3.1 and 5).

A frame is a *ground* frame when any foot point (ankle point or toe tip, left or right) touches the
ground (the detector's ``touching``: near its support level, whatever its speed, as the audit's
phases; a point given by the overrides touches exactly where it is planted), a *flight* frame
otherwise: a foot rolling off at take-off still pushes. The support polygon is made of the planted
points (as the audit's ZMP measure). The plants are the project's (:func:`mocomp.ops.foot_plants`: the
contact detector, with ``joint,start,stop`` CSV overrides); the paper stresses that the labels must
be accurate (sec. 5), so :class:`Stages` lists every stage and where each foot point's labels came
from. Labels that contradict the motion (a planted point that travels more than
``max_plant_travel`` during its plant) are an error naming the point and the frames.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..errors import MocompError
from ..ops import foot_plants
from ..ops.footplant import foot_points

__all__ = ["Stages", "StageError", "stages", "runs", "MAX_PLANT_TRAVEL", "POLYGONS"]

#: support polygons: of the touching foot points (the contact region) or of the planted ones
POLYGONS = ("contact", "planted")

#: m: a planted foot point that moves farther than this (horizontally) within one plant is a label
#: that contradicts the motion
MAX_PLANT_TRAVEL = 0.3


class StageError(MocompError, ValueError):
    """Stages cannot be found, or the contact labels contradict the motion."""


def runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """Half-open ``(start, stop)`` runs of True in a ``(T,)`` bool array
    (:func:`mocomp.dynamics.contacts.label_intervals`)."""
    from ..dynamics.contacts import label_intervals

    return label_intervals(mask)


@dataclass(frozen=True, eq=False)
class Stages:
    """Stage labels of a motion.

    Attributes
    ----------
    plants: the :class:`~mocomp.ops.FootPlants` (foot_l, toe_l, foot_r, toe_r).
    ground: ``(T,)`` bool, any foot point touching.
    touching: ``(T, 4)`` bool, foot points touching the ground (planted ones included).
    contact_points: ``(T, 4, 3)`` m, the foot points on the input motion (the support polygon's
        corners where planted).
    """

    plants: object
    ground: np.ndarray
    contact_points: np.ndarray
    touching: np.ndarray = None

    @property
    def n_frames(self) -> int:
        return int(self.ground.shape[0])

    @property
    def ground_runs(self) -> list[tuple[int, int]]:
        return runs(self.ground)

    @property
    def flight_runs(self) -> list[tuple[int, int]]:
        """Flights strictly inside the clip (a clip that starts or ends in the air has no
        block end points on the ground to fit a parabola through; those runs are left out)."""
        T = self.n_frames
        return [(a, b) for a, b in runs(~self.ground) if a > 0 and b < T]

    @property
    def contact_mask(self) -> np.ndarray:
        """``(T, 4)`` bool, planted foot points."""
        return np.asarray(self.plants.labels, bool)

    def polygon_mask(self, polygon: str = "contact") -> np.ndarray:
        """``(T, 4)`` bool: the foot points that make the support polygon. ``"contact"`` (default):
        every point touching the ground -- the paper's "convex hull of the contact region" (sec. 3.1);
        ``"planted"``: the planted points only, as the audit's ZMP measure. The two differ in double
        support: the landing heel touches (and takes the weight) frames before it stops, and the
        rolling-off foot still touches while its heel rises; with planted points only the polygon
        is the trailing toe alone there, and an unedited Bandai walk shows the ZMP 10-26 cm
        outside it on every step (mean 4.8 cm over the clip, 1.8 cm with the contact region)."""
        if polygon == "contact":
            return np.asarray(self.touching, bool)
        if polygon == "planted":
            return self.contact_mask
        raise ValueError(f"polygon must be one of {', '.join(POLYGONS)}, got {polygon!r}")

    def to_dict(self) -> dict:
        p = self.plants
        return {"ground": [list(r) for r in self.ground_runs],
                "flight": [list(r) for r in runs(~self.ground)],
                "flights_adjusted": [list(r) for r in self.flight_runs],
                "plants": {e: {"intervals": [list(r) for r in runs(p.labels[:, k])], "source": p.source[e]}
                           for k, e in enumerate(p.effectors)},
                "ground_frames": int(self.ground.sum()), "frames": self.n_frames}


def stages(motion, contacts=None, *, max_plant_travel: float = MAX_PLANT_TRAVEL) -> Stages:
    """Ground and flight stages of ``motion`` from its foot plants (``contacts``: overrides, a CSV
    path ``joint,start,stop`` or effector -> intervals, :func:`mocomp.ops.foot_plants`).

    Raises :class:`StageError` when no frame is a ground frame, or when a planted point moves more
    than ``max_plant_travel`` m horizontally within one plant (labels contradicting the motion)."""
    from ..ops.plants import NoContactError

    if not (np.isfinite(max_plant_travel) and max_plant_travel > 0):
        raise ValueError(f"max_plant_travel must be a positive distance in m, got {max_plant_travel!r}")
    try:
        plants = foot_plants(motion, contacts, require=True)
    except NoContactError as e:
        raise StageError(f"no ground frames: {e}") from e
    lab = np.array(plants.labels, bool)
    if isinstance(contacts, dict):                  # an effector given no interval: never planted
        source = dict(plants.source)
        for e, iv in contacts.items():
            if not list(iv) and e in plants.effectors:
                lab[:, plants.effectors.index(e)] = False
                source[e] = "given"
        plants = dataclasses.replace(plants, labels=lab, levels=np.where(lab, plants.levels, np.nan), source=source)
    if not lab.any():
        raise StageError(f"no ground frames: no foot point is planted on any of the {motion.n_frames} frames "
                         "of the contacts given")
    P, G = motion.fk()
    pts = foot_points(P, G, plants)
    for k, e in enumerate(plants.effectors):
        for a, b in runs(lab[:, k]):
            xz = pts[a:b, k][:, [0, 2]]
            travel = float(np.linalg.norm(xz - xz[0], axis=1).max())
            if travel > max_plant_travel:
                raise StageError(
                    f"contacts ({plants.source[e]}): {e} is labelled planted on frames {a}-{b - 1} but moves "
                    f"{travel:.2f} m there (more than {max_plant_travel:g} m): the labels contradict the motion")
    touch = np.array(lab)
    c = plants.contacts
    if c is not None and getattr(c, "touching", None) is not None:
        for k, e in enumerate(plants.effectors):
            if plants.source[e] == "detector" and e in c.effectors:
                touch[:, k] |= np.asarray(c.touching)[:, c.effectors.index(e)]
    ground = touch.any(axis=1)
    return Stages(plants, ground, pts, touch)
