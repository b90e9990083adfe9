"""Angular-momentum-guided concatenation of dynamic motions (Shum, Komura & Yadav 2009; issue 17).

* :func:`momentum_track` (eq. 1) and :func:`find_phases` (preparatory, main, posterior);
* :func:`choose_rule` (forward / reverse, or auto with the reason), :func:`alignment_yaw` (eq. 2,
  closed form), :func:`blendable_periods`;
* :func:`timing_table` / :func:`optimal_timing` (eq. 3-7 over the whole (T, f) table at once);
* :func:`concatenate`: the whole method, eq. 8 blending and the supporting feet held
  (:mod:`mocomp.ops`);
* :func:`find_actions` / :func:`cut_actions`: single strikes cut out of a take holding several;
* the baseline: :func:`motion_graph_concatenate`, the Motion-Graph transition (Kovar et al. 2002's
  point-cloud distance, :func:`point_cloud_table`) blended the same way.
"""
from .actions import Action, cut_actions, find_actions
from .baseline import CloudTable, MotionGraphTransition, motion_graph_transition, point_cloud_table
from .method import (MAX_FACING, BaselineResult, ConcatResult, check_same_skeleton, concatenate, linear_blend,
                     motion_graph_concatenate)
from .phases import MIN_MAIN_LEVEL, ConcatError, MomentumTrack, Phases, find_phases, momentum_track
from .rules import RULES, RuleChoice, alignment_yaw, blendable_periods, choose_rule, support_truncate
from .timing import TimingTable, optimal_timing, timing_table

__all__ = ["Action", "find_actions", "cut_actions", "ConcatError", "MomentumTrack", "Phases", "momentum_track", "find_phases", "MIN_MAIN_LEVEL",
           "RULES", "RuleChoice", "choose_rule", "alignment_yaw", "blendable_periods", "support_truncate",
           "TimingTable", "timing_table", "optimal_timing",
           "ConcatResult", "concatenate", "check_same_skeleton", "MAX_FACING", "linear_blend",
           "CloudTable", "point_cloud_table", "MotionGraphTransition", "motion_graph_transition",
           "BaselineResult", "motion_graph_concatenate"]
