"""Body height (stature) of a motion's performer, robust to crouching clips, raised arms and props.

Two estimates, both in the motion's length unit (metres for loaded clips):

* **measured** (``motion_extent``): the 95th percentile over frames of the
  vertical distance from the top of the head (landmark ``VERT``, carried by the
  head joint) down to the lowest foot point (ankle joints ``AJC`` and toe tips
  ``TTIP`` of both feet). Only the head-to-foot line counts, so arms raised
  overhead or a sword held up do not inflate it (the plain vertical extent of
  all joints, :func:`mocomp.io.units.standing_height`, counts them).
* **from the skeleton** (``chain``): the stature of the skeleton standing
  straight, the sum of its bone lengths from the sole to the head top:
  ``ankle height + shank + thigh + MIDH->CERV + CERV->VERT``, where shank =
  ``|KJC - AJC|`` and thigh = ``|HJC - KJC|`` (mean of the two sides), MIDH is the
  midpoint of the hip joints, CERV the base of the neck, and the ankle height is
  how far the ankle lies above the toe tip along the shank axis in the rest
  pose (mean of both sides; where the rest pose's feet are not at a standing
  angle to the shanks, >= 45 degrees, e.g. Bandai Namco's feet in line with the
  shank, it is 0.039 x stature: Drillis & Contini 1966, Winter 2009 Fig. 4.1). The head-top allowance above the head joint and
  the toe tip below the ankle are the convention's ``VERT`` and ``TTIP``
  landmarks (:mod:`mocomp.body.mapping`; e.g. ASE: head top 0.27 m above the
  head joint, sole 0.05 m below the ankle, from its MJCF body shapes, so the
  ASE humanoid's chain is 1.611 m, the MJCF's own standing height). The rest
  pose need not be upright: only lengths and the shank axis enter.

Criterion: a clip **stands upright** when its measured extent reaches at least
``upright`` (default 0.97) of the skeleton chain, i.e. in at least 5 % of the
frames the head top is within 3 % of where it would be with straight legs and
trunk (a relaxed stance costs less than that: 15 degrees of knee flexion
shortens the leg by ~1.5 %, a 15 degree trunk lean the trunk by ~1 %). Then the
measured extent is the height (``basis="motion"``); otherwise the clip never
stands up straight (a crouching charge, a fall, a ready stance) and the skeleton
chain is (``basis="skeleton"``). Skeletons that no body-segment mapping fits
keep the all-joints vertical extent (``basis="joints"``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.rotations import quat_apply
from ..errors import MotionFormatError

__all__ = ["HeightEstimate", "estimate_height", "standing_height", "skeleton_stature", "UPRIGHT_FRACTION",
           "ANKLE_HEIGHT_FRACTION"]

#: measured head-to-foot extent / straight-chain stature at or above which a clip stands upright
UPRIGHT_FRACTION = 0.97

#: ankle height / stature where the rest pose does not show it (Drillis & Contini 1966 segment
#: proportions, as in Winter 2009, Fig. 4.1: ankle height 0.039 H)
ANKLE_HEIGHT_FRACTION = 0.039


@dataclass(frozen=True)
class HeightEstimate:
    """A body-height estimate and the evidence behind it.

    Attributes
    ----------
    value: the height, in the motion's length unit (metres for loaded clips).
    basis: ``"motion"`` (measured head-top to foot extent), ``"skeleton"`` (straight
        chain of bone lengths: the clip never stands upright) or ``"joints"`` (no
        mapping fits: 95th percentile of the vertical extent of all joints and end sites).
    motion_extent: the measured head-to-foot extent (95th percentile over frames); for
        ``"joints"`` the all-joints extent.
    chain: the skeleton's straight-standing stature, ``None`` without a mapping.
    ratio: ``motion_extent / chain`` (``None`` without a mapping).
    convention: the body-segment mapping used, or ``None``.
    reason: one line saying which estimate was taken and why.
    """

    value: float
    basis: str
    motion_extent: float
    chain: float | None
    ratio: float | None
    convention: str | None
    reason: str


def _joint_extent(motion, percentile: float) -> float:
    P = motion.positions
    E = motion.end_site_positions()
    allp = np.concatenate([P, E], axis=1) if E.shape[1] else P
    ext = allp[..., 1].max(axis=1) - allp[..., 1].min(axis=1)
    return float(np.percentile(ext, percentile))


def _landmarks(skeleton, resolved):
    from .mapping import resolve_landmark

    lm = resolved.convention.landmarks
    rest = skeleton.rest_positions()

    def get(k):
        p = resolve_landmark(skeleton, lm[k], lm, rest)
        if p is None:
            raise MotionFormatError(f"mapping {resolved.convention.name!r}: landmark {k!r} does not resolve")
        return p

    return get, rest


def skeleton_stature(skeleton, mapping=None) -> float:
    """Straight-standing stature of ``skeleton`` from its bone lengths (see the module
    docstring), in its length unit. Raises :class:`~mocomp.errors.MotionFormatError`
    when no body-segment mapping fits (``mapping`` as for :func:`~mocomp.body.mapping.resolve_mapping`)."""
    from .mapping import resolve_mapping

    rm = resolve_mapping(skeleton, mapping)
    get, _ = _landmarks(skeleton, rm)
    legs, ankles = [], []
    for s in ("l", "r"):
        hjc, kjc, ajc, ttip = get(f"HJC_{s}"), get(f"KJC_{s}"), get(f"AJC_{s}"), get(f"TTIP_{s}")
        shank = np.linalg.norm(kjc - ajc)
        legs.append(np.linalg.norm(hjc - kjc) + shank)
        foot = ttip - ajc
        if shank > 0 and np.linalg.norm(foot) > 0:
            axis = (kjc - ajc) / shank
            # the rest pose's foot must stand at a standing angle to the shank (>= 45 deg from the
            # shank's downward line) for its projection to be the ankle height
            if np.dot(-axis, foot) / np.linalg.norm(foot) <= np.cos(np.radians(45.0)):
                ankles.append(max(0.0, float(np.dot(-foot, axis))))
    trunk = np.linalg.norm(get("CERV") - get("MIDH"))
    head = np.linalg.norm(get("VERT") - get("CERV"))
    body = float(np.mean(legs) + trunk + head)
    if len(ankles) == 2:
        return body + float(np.mean(ankles))
    # rest-pose feet in line with the shanks (e.g. Bandai Namco): ankle height 0.039 x stature
    return body / (1.0 - ANKLE_HEIGHT_FRACTION)


def estimate_height(motion, mapping=None, upright: float = UPRIGHT_FRACTION,
                    percentile: float = 95.0) -> HeightEstimate:
    """The performer's height from ``motion`` (see the module docstring for both estimates
    and the upright criterion).

    Parameters
    ----------
    motion: a :class:`~mocomp.core.Motion`.
    mapping: body-segment mapping (``None``: detect the naming convention; a convention
        name, :class:`~mocomp.body.mapping.SegmentMap` or override dict as for
        :func:`~mocomp.body.mapping.resolve_mapping`). When none fits, the all-joints
        extent is returned with ``basis="joints"``.
    upright: the measured / chain ratio at or above which the clip stands upright.
    percentile: percentile over frames of the measured extent.
    """
    from .mapping import detect_convention, resolve_mapping

    if not (0.0 < upright <= 1.5):
        raise ValueError(f"upright must be a ratio in (0, 1.5], got {upright!r}")
    sk = motion.skeleton
    try:
        conv = detect_convention(sk) if mapping is None else None
        rm = resolve_mapping(sk, conv if conv is not None else mapping)
    except MotionFormatError:
        if mapping is not None:
            raise
        ext = _joint_extent(motion, percentile)
        return HeightEstimate(ext, "joints", ext, None, None, None,
                              "no body-segment mapping fits this skeleton: 95th percentile of the vertical extent "
                              "of all joints and end sites")
    get, rest = _landmarks(sk, rm)
    car = rm.convention.carriers
    P, Q = motion.positions, motion.global_rotations

    def track(name: str, carrier: str) -> np.ndarray:
        j = sk.find(carrier)
        return P[:, j, 1] + quat_apply(Q[:, j], np.broadcast_to(get(name) - rest[j], (motion.n_frames, 3)))[:, 1]

    top = track("VERT", car["head"])
    low = np.min([track(f"{k}_{s}", car[f"foot_{s}"]) for s in ("l", "r") for k in ("AJC", "TTIP")], axis=0)
    measured = float(np.percentile(top - low, percentile))
    chain = skeleton_stature(sk, rm.convention)
    ratio = measured / chain if chain > 0 else float("inf")
    name = rm.convention.name
    if ratio >= upright:
        return HeightEstimate(measured, "motion", measured, chain, ratio, name,
                              f"stands upright (head-to-foot extent {ratio:.1%} of the straight-chain stature "
                              f"{chain:.3f}): measured head-top to foot extent")
    return HeightEstimate(chain, "skeleton", measured, chain, ratio, name,
                          f"never stands upright (head-to-foot extent {measured:.3f}, {ratio:.1%} of the "
                          f"straight chain, below {upright:.0%}): stature from the skeleton's bone lengths")


def standing_height(motion, mapping=None) -> float:
    """``estimate_height(motion, mapping).value``: the performer's height in the motion's unit."""
    return estimate_height(motion, mapping).value
