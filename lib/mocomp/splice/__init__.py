"""Hand/body splicing with two-stage banded DTW (dissertation ch. 6)."""
from .bands import Band, MatchPoint, full_band, matching_band, slanted_band
from .dtw import DTWResult, dtw
