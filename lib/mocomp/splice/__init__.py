"""Hand/body splicing with two-stage banded dynamic time warping (dissertation ch. 6).

Layers, bottom up:

* :mod:`~mocomp.splice.bands`: the slanted band (eq. 6.3) and its reshaping
  by user matching points (eq. 6.4-6.5, Algorithm 1); O(band) storage.
* :mod:`~mocomp.splice.dtw`: the DTW recurrence (eq. 6.1-6.2) on a band,
  compiled; agrees with dtw-python's ``symmetric1`` (cost and path).
* :mod:`~mocomp.splice.markers`: the four hand markers from C3D or as virtual
  markers on a skeleton's forearm and hand.
* :mod:`~mocomp.splice.metrics`: the sign metric (eq. 6.6-6.7), its
  value-based foil, the hand-angle metric (eq. 6.8-6.9).
* :mod:`~mocomp.splice.phases`: Table 6.1 phase labels, strokes one by one.
* :mod:`~mocomp.splice.subsequence`: open-begin/open-end DTW (a short hand
  clip located in a long body take); agrees with dtw-python's.
* :mod:`~mocomp.splice.warpmap`: the tube of near-optimal alignments and the
  least-distorting (taut-string) frame map through it.
* :mod:`~mocomp.splice.align`: the two-stage alignment.
* :mod:`~mocomp.splice.merge` / :mod:`~mocomp.splice.pipeline`: median merge,
  blending, the spliced motion (:func:`splice_motions`, :func:`splice_markers`).
* :mod:`~mocomp.splice.quality`: the splice's own quality checks (frozen or
  reversed hand, warp slope, eq. 6.9 residual) and verified matching-point
  suggestions.
* :mod:`~mocomp.splice.jointmap`: pairing the layer's joints across naming
  conventions (``--map FILE.toml``).
* :mod:`~mocomp.splice.synthetic`: ground-truth pairs with a known warp.
"""
from .align import Alignment, SpliceConfig, align_hands, alignment_error
from .bands import Band, MatchPoint, corridor_band, full_band, matching_band, parse_match, slanted_band
from .dtw import DTWResult, dtw, dtw_band_costs
from .markers import HandMarkers, hand_markers_from_markers, virtual_hand_markers
from .phases import PhaseLabels, motion_phases
from .jointmap import JointMap, load_joint_map, pair_joints
from .pipeline import SpliceResult, splice_markers, splice_motions
from .quality import QualityThresholds, SpliceQuality, Stretch, Suggestion, measure_quality, suggest_points
from .subsequence import SubsequenceResult, subsequence_dtw
from .warpmap import frame_map, near_optimal_tube, rasterize_map, taut_string, through_costs

__all__ = [
    "Band", "MatchPoint", "full_band", "slanted_band", "matching_band", "corridor_band", "parse_match",
    "DTWResult", "dtw", "dtw_band_costs",
    "HandMarkers", "virtual_hand_markers", "hand_markers_from_markers",
    "PhaseLabels", "motion_phases",
    "SpliceConfig", "Alignment", "align_hands", "alignment_error",
    "SpliceResult", "splice_motions", "splice_markers",
    "through_costs", "near_optimal_tube", "taut_string", "frame_map", "rasterize_map",
    "QualityThresholds", "SpliceQuality", "Stretch", "Suggestion", "measure_quality", "suggest_points",
    "SubsequenceResult", "subsequence_dtw", "JointMap", "load_joint_map", "pair_joints",
]
