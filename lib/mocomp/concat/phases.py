"""Angular momentum trajectory (Shum, Komura & Yadav 2009, eq. 1) and the three phases of a motion.

``L(t) = sum_j m_j r_j(t) x p_j(t)`` (eq. 1): ``r_j`` the moment arm from the whole-body centre of
mass to the COM of segment ``j``, ``p_j`` its velocity, ``m_j`` its mass. The segments, masses,
positions and velocities are the project's (:func:`mocomp.dynamics.momentum` on the body model of
:func:`mocomp.audit.default_body`); eq. 1 is the orbital part of the angular momentum about the
COM (the segments' own spin ``I_j w_j`` is left out, as in the paper); ``kind="full"`` takes the
project's complete ``L`` instead.

Phases (sec. "Typical Angular Momentum Trajectories"): from a frame ``t_m`` in the main phase
(default the peak of ``|L|``) walk backward to the first frame with ``L(t) . L(t_m) < 0``: the main
phase starts after it and everything before is the preparatory phase; likewise forward for the
posterior phase. Either border may be given by hand.

Captured motions rarely return to exactly zero momentum: after a flip the body stands with a
small |L| of noise whose sign stays that of the flip, and the sign test alone then runs the main
phase through the whole quiet tail (CMU 88_01: main 16-148 of 202 frames, the flip being frames
20-75). So the walk stops where ``L(t)`` projected on the direction of ``L(t_m)`` falls below
``level_fraction`` of ``|L(t_m)|`` (default :data:`LEVEL_FRACTION`, 0.1; ``0`` is the paper's rule
exactly).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import MocompError

__all__ = ["body_of", "LEVEL_FRACTION", "ConcatError", "MomentumTrack", "Phases", "momentum_track", "find_phases", "L_KINDS", "MIN_MAIN_LEVEL"]

L_KINDS = ("paper", "full")
#: kg m^2/s: a motion whose |L| never exceeds this has no main phase (a person standing, shifting
#: weight or walking slowly stays below ~3; a punch peaks at ~5-15, a spinning kick or a flip at 20-50)
MIN_MAIN_LEVEL = 4.0
#: the main phase ends where L projected on L(t_m)'s direction falls below this fraction of |L(t_m)|
LEVEL_FRACTION = 0.1
#: s, Gaussian sigma of the pre-smoothing of the motion before differentiating (capture noise)
SMOOTH_SECONDS = 0.02


class ConcatError(MocompError, ValueError):
    """Two motions cannot be concatenated as asked (no main phase, a rule that cannot apply, the
    facing check or the timing threshold failed); the message states the measured value."""


@dataclass(frozen=True, eq=False)
class MomentumTrack:
    """A motion's angular momentum trajectory and what eq. 6 needs.

    Attributes
    ----------
    L: ``(T, 3)`` kg m^2/s, eq. 1 (or the full L with ``kind="full"``), world axes (y up).
    arms: ``(T, S, 3)`` m, moment arms ``r_j`` (segment COM minus body COM).
    masses: ``(S,)`` kg.
    fps: frames per second.
    kind: ``"paper"`` (eq. 1) or ``"full"``.
    """

    L: np.ndarray
    arms: np.ndarray
    masses: np.ndarray
    fps: float
    kind: str = "paper"

    @property
    def n_frames(self) -> int:
        return len(self.L)

    @property
    def magnitude(self) -> np.ndarray:
        return np.linalg.norm(self.L, axis=1)

    def rotated(self, quat) -> "MomentumTrack":
        """The track of the motion turned by the rotation ``quat`` (L and the arms rotate with it)."""
        from ..core.rotations import quat_apply

        q = np.asarray(quat, dtype=float)
        return MomentumTrack(quat_apply(q, self.L), quat_apply(q, self.arms), self.masses, self.fps, self.kind)


#: the body models :func:`body_of` keeps (a chain or a benchmark concatenates the same skeleton again)
_BODIES: dict = {}
_BODIES_MAX = 8


def body_of(motion):
    """:func:`mocomp.audit.default_body` of ``motion``, kept for the next call with the same skeleton and
    source notes (all it depends on: a DeepMimic clip's character file, named in the loader's notes, is
    parsed once, ~7 ms, instead of on every concatenation). The model is shared: read it, do not change it."""
    from ..audit import default_body

    sk, src = motion.skeleton, motion.source
    key = (getattr(src, "format", None), tuple(getattr(src, "notes", ()) or ()), tuple(sk.names),
           np.asarray(sk.parents).tobytes(), np.asarray(sk.offsets, dtype=float).tobytes())
    body = _BODIES.get(key)
    if body is None:
        body = default_body(motion)
        if len(_BODIES) >= _BODIES_MAX:
            _BODIES.pop(next(iter(_BODIES)))
        _BODIES[key] = body
    return body


def momentum_track(motion, body=None, *, kind: str = "paper", smooth_seconds: float | None = SMOOTH_SECONDS
                   ) -> MomentumTrack:
    """Eq. 1 over every frame of ``motion`` (body model: ``body`` or :func:`mocomp.audit.default_body`)."""
    from ..dynamics import momentum

    if kind not in L_KINDS:
        raise ValueError(f"kind must be one of {', '.join(L_KINDS)}, got {kind!r}")
    body = body_of(motion) if body is None else body
    sigma = smooth_seconds * motion.fps if smooth_seconds else None
    r = momentum(body, motion, smooth_sigma=sigma if sigma and sigma >= 0.5 else None)
    arms = r.segment_positions - r.com[:, None]
    if kind == "paper":
        m = np.asarray(body.masses, dtype=float)
        L = np.einsum("s,tsk->tk", m, np.cross(arms, r.segment_velocities))
    else:
        L = np.asarray(r.angular)
    return MomentumTrack(L, arms, np.asarray(body.masses, dtype=float), float(motion.fps), kind)


@dataclass(frozen=True)
class Phases:
    """Half-open frame ranges: preparatory ``[0, main[0])``, main ``[main[0], main[1])``,
    posterior ``[main[1], n)``; ``t_m`` the reference frame; ``given`` whether the borders were set by hand."""

    n_frames: int
    t_m: int
    main: tuple[int, int]
    given: bool = False

    @property
    def preparatory(self) -> tuple[int, int]:
        return (0, self.main[0])

    @property
    def posterior(self) -> tuple[int, int]:
        return (self.main[1], self.n_frames)

    def to_dict(self) -> dict:
        return {"t_m": self.t_m, "preparatory": list(self.preparatory), "main": list(self.main),
                "posterior": list(self.posterior), "borders": "given" if self.given else "detected"}


def find_phases(track: MomentumTrack, t_m: int | None = None, borders: tuple[int, int] | None = None, *,
                min_level: float = MIN_MAIN_LEVEL, level_fraction: float = LEVEL_FRACTION,
                name: str = "the motion") -> Phases:
    """Segment a motion into preparatory, main and posterior phases (see the module docstring).

    ``level_fraction``: the walk stops below this fraction of ``|L(t_m)|`` along its direction
    (0: at the first ``L(t) . L(t_m) < 0``, the paper's rule).
    ``borders=(m0, m1)``: the main phase is ``[m0, m1)`` as given (``t_m`` then defaults to the
    peak of ``|L|`` inside it). Raises :class:`ConcatError` when ``|L|`` never exceeds ``min_level``
    (no main phase) or the borders are out of range.
    """
    L = track.L
    n = len(L)
    mag = np.linalg.norm(L, axis=1)
    if borders is not None:
        m0, m1 = (int(x) for x in borders)
        if not 0 <= m0 < m1 <= n:
            raise ConcatError(f"{name}: main phase borders {m0},{m1} must satisfy 0 <= start < stop <= {n} "
                              f"(the motion has {n} frames)")
        tm = int(m0 + np.argmax(mag[m0:m1])) if t_m is None else int(t_m)
        return Phases(n, tm, (m0, m1), True)
    peak = float(mag.max()) if n else 0.0
    if peak < min_level:
        raise ConcatError(f"{name} has no main phase: |L| peaks at {peak:.2f} kg m^2/s (frame "
                          f"{int(np.argmax(mag)) if n else 0}), never above {min_level:g} kg m^2/s")
    tm = int(np.argmax(mag)) if t_m is None else int(t_m)
    if not 0 <= tm < n:
        raise ConcatError(f"{name}: t_m {tm} is outside the motion's frames 0-{n - 1}")
    ref = float(np.linalg.norm(L[tm]))
    neg = (L @ L[tm]) < level_fraction * ref * ref if ref > 0 else np.ones(n, bool)
    before = np.flatnonzero(neg[:tm])
    after = np.flatnonzero(neg[tm:])
    m0 = int(before[-1]) + 1 if before.size else 0
    m1 = tm + int(after[0]) if after.size else n
    return Phases(n, tm, (m0, m1), False)
