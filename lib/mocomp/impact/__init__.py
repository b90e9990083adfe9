"""Impact response: a motion-captured character hit unexpectedly (dissertation ch. 4, App. A).

A short physics burst (MuJoCo) produces the physical reaction, a search finds the library clip
that best continues it, an active simulation steers toward that clip with inertia-scaled PD servos
(eq. 4.3), and a final blend lands exactly on it; the attacker follows the contact for a few
frames and blends back to its attack.

Modules (imported on use, so ``import mocomp.impact`` stays cheap):

* :mod:`~mocomp.impact.scene` -- both characters in one MuJoCo model (MJCF from
  :mod:`mocomp.body.mjcf`, collision geoms, joint limits from the captured range, placement);
* :mod:`~mocomp.impact.convert` -- MuJoCo ``qpos``/``qvel`` <-> :class:`~mocomp.core.Motion`;
* :mod:`~mocomp.impact.simulate` -- kinematic driving to first contact, rewind, the naive and
  the active simulation;
* :mod:`~mocomp.impact.blend` -- the final blend onto the found clip (root error spread
  linearly, joints slerped), feet planted;
* :mod:`~mocomp.impact.attacker` -- the attacker follows the contact, then blends back;
* :mod:`~mocomp.impact.pipeline` -- the whole response with evidence and per-stage timings;
* :mod:`~mocomp.impact.features`, :mod:`~mocomp.impact.index`, :mod:`~mocomp.impact.search` --
  the motion search (eq. 4.1-4.2, unique frames) over a cached library index.
"""
