"""Bands of eq. 6.3-6.5 / Algorithm 1: geometry, matching points, errors."""
from __future__ import annotations

import numpy as np
import pytest

from mocomp.errors import AlignmentError
from mocomp.splice import MatchPoint, full_band, matching_band, parse_match, slanted_band
from mocomp.splice.bands import band_radius, corridor_band


def test_width_is_perpendicular_half_width():
    """Eq. 6.3: rho = W sqrt(n^2 + m^2) / n makes W the distance from the
    diagonal measured perpendicular to it (0-based corner-to-corner line)."""
    n, m, W = 300, 500, 12.0
    band = slanted_band(n, m, W)
    rho = band.radii[0]
    assert rho == pytest.approx(W * np.hypot(n - 1, m - 1) / (n - 1))
    i, j = band.cell_indices()
    # perpendicular distance of each cell from the line through (0,0) and (n-1,m-1)
    d = np.abs((m - 1) * i - (n - 1) * j) / np.hypot(n - 1, m - 1)
    assert d.max() <= W + 1e-9
    # cells just outside the band (raw edges +- 1) are farther than W
    rows = np.arange(n)
    for jj in (band.raw_lo - 1, band.raw_hi + 1):
        ok = (jj >= 0) & (jj < m)
        dd = np.abs((m - 1) * rows[ok] - (n - 1) * jj[ok]) / np.hypot(n - 1, m - 1)
        assert dd.min() > W - 1e-9


def test_band_radius_formula():
    assert band_radius(10, 100, 100) == pytest.approx(10 * np.sqrt(2))
    assert band_radius(10, 100, 0) == pytest.approx(10)
    with pytest.raises(AlignmentError):
        band_radius(10, 0, 5)


def test_no_points_is_the_slanted_band():
    a = slanted_band(80, 95, 9.5)
    b = matching_band(80, 95, 9.5, [])
    np.testing.assert_array_equal(a.lo, b.lo)
    np.testing.assert_array_equal(a.hi, b.hi)
    assert a.kind == "slanted"


def test_points_reshape_the_band_piecewise():
    """Eq. 6.4: between consecutive anchors the band is the slanted band of
    that segment; eq. 6.5: clipped to [y_{k-1} - T_{k-1}, y_k + T_k]; the
    point's row is its tolerance window."""
    n, m, W = 200, 150, 10.0
    p1, p2 = MatchPoint(50, 90, 0), MatchPoint(140, 110, 4)
    band = matching_band(n, m, W, [p1, p2])
    assert band.kind == "points" and band.points == (p1, p2)
    assert (band.raw_lo[p1.x], band.raw_hi[p1.x]) == (90, 90)
    assert (band.raw_lo[p2.x], band.raw_hi[p2.x]) == (106, 114)
    # rows of segment 2 follow the line from (50, 90) to (140, 110), radius rho_2
    rho2 = band_radius(W, 90, 20)
    assert band.radii[1] == pytest.approx(rho2)
    for i in (70, 100, 120):
        c = 90 + (i - 50) * 20 / 90
        assert band.raw_lo[i] == max(int(np.ceil(c - rho2)), 90)  # clipped at y_1 - T_1 = 90
        assert band.raw_hi[i] == min(int(np.floor(c + rho2)), 114)  # clipped at y_2 + T_2
    # segment 1 has the steep slope 90/50 and its own radius
    assert band.radii[0] == pytest.approx(band_radius(W, 50, 90))
    assert band.lo[0] == 0 and band.hi[-1] == m - 1
    assert np.all(np.diff(band.lo) >= 0) and np.all(np.diff(band.hi) >= 0)


def test_a_point_outside_the_slanted_band_reshapes_it():
    """Algorithm 1: points are honoured wherever they lie in the matrix; one
    outside the eq. 6.3 band bends the band to it (no error), and the optimal
    path passes through it exactly."""
    from mocomp.splice import dtw

    n, m, W = 120, 100, 5.0
    plain = slanted_band(n, m, W)
    p = MatchPoint(30, 70, 0)
    assert not plain.contains(p.x, p.y)
    res = dtw(cost=np.random.default_rng(0).random((n, m)), width=W, points=[p])
    np.testing.assert_array_equal(res.matches(p.x), [p.y])


def test_strict_points_raise_outside_the_band_naming_the_limits():
    """Opt-in strict mode: a point whose window misses the eq. 6.3 band in its
    row raises, naming the point and the band's columns there; a point (or a
    tolerance window) touching the band passes, and the band is then the
    same as without strict mode."""
    n, m, W = 120, 100, 5.0
    plain = slanted_band(n, m, W)
    a, b = int(plain.raw_lo[30]), int(plain.raw_hi[30])
    with pytest.raises(AlignmentError, match=rf"point 1 \(30:70\) is outside the band .*body frame 30 allows hand frames {a}\.\.{b}"):
        matching_band(n, m, W, [MatchPoint(30, 70)], strict=True)
    lo60, hi60 = int(plain.raw_lo[60]), int(plain.raw_hi[60])
    with pytest.raises(AlignmentError, match=rf"point 2 \(60:{lo60 - 4}~3\) is outside the band .*frames {lo60}\.\.{hi60}"):
        matching_band(n, m, W, [MatchPoint(30, a), MatchPoint(60, lo60 - 4, 3)], strict=True)
    matching_band(n, m, W, [MatchPoint(30, a), MatchPoint(60, lo60 - 3, 3)], strict=True)  # touches the band
    for pts in ([MatchPoint(30, b)], [MatchPoint(30, a)], [MatchPoint(30, b + 4, 4)]):
        s, r = matching_band(n, m, W, pts, strict=True), matching_band(n, m, W, pts)
        np.testing.assert_array_equal(s.lo, r.lo)
        np.testing.assert_array_equal(s.hi, r.hi)
    with pytest.raises(AlignmentError, match=r"point 1 \(30:%d~3\)" % (b + 4)):
        matching_band(n, m, W, [MatchPoint(30, b + 4, 3)], strict=True)


def test_fully_specified_points_need_equal_lengths():
    """The 'fully specified' end of the continuum: an exact point on every
    inner body frame pins the path to them for n == m; for n != m the
    errors say why it cannot work."""
    from mocomp.splice import dtw

    n = 40
    cost = np.random.default_rng(3).random((n, n))
    pts = [(i, i) for i in range(1, n - 1)]
    res = dtw(cost=cost, width=2.0, points=pts)
    np.testing.assert_array_equal(res.path, np.stack([np.arange(n)] * 2, axis=1))
    with pytest.raises(AlignmentError, match="same length"):
        matching_band(n, n + 10, 2.0, [(i, i + (i > 20) * 10) for i in range(1, n - 1)])
    with pytest.raises(AlignmentError, match="out of order.*as many hand frames as body frames"):
        matching_band(n, n - 10, 2.0, [(i, min(i, n - 12)) for i in range(1, n - 1)])


def test_pruned_band_keeps_only_cells_on_monotone_paths():
    band = matching_band(60, 60, 6.0, [MatchPoint(30, 10, 0)])
    # every kept row range connects to the next one
    assert np.all(band.lo[1:] <= band.hi[:-1] + 1)
    assert np.all(band.lo <= band.hi)
    raw = (np.arange(60)[None] >= band.raw_lo[:, None]) & (np.arange(60)[None] <= band.raw_hi[:, None])
    assert np.all(band.mask() <= raw)


def test_flat_indexing_roundtrip():
    band = slanted_band(37, 53, 5.0)
    i, j = band.cell_indices()
    np.testing.assert_array_equal(band.flat_index(i, j), np.arange(band.cells))
    dense = band.to_dense(np.arange(band.cells, dtype=float))
    assert np.isnan(dense[~band.mask()]).all()
    np.testing.assert_array_equal(dense[i, j], np.arange(band.cells))
    assert band.contains(i, j).all()
    assert not band.contains(0, 52)


def test_corridor_band():
    path = np.array([[0, 0], [1, 1], [1, 2], [2, 3], [3, 3], [4, 4]])
    b = corridor_band(path, 5, 5, 1)
    np.testing.assert_array_equal(b.lo, [0, 0, 2, 2, 3])
    np.testing.assert_array_equal(b.hi, [1, 3, 4, 4, 4])


@pytest.mark.parametrize("text,expect", [("120:95", MatchPoint(120, 95, 0)), ("300:280~5", MatchPoint(300, 280, 5)),
                                         (" 3 : 4 ~ 1 ", MatchPoint(3, 4, 1))])
def test_parse_match(text, expect):
    assert parse_match(text) == expect
    assert parse_match(str(expect)) == expect


@pytest.mark.parametrize("bad", ["120", "a:b", "1:2~", "1:2:3", ""])
def test_parse_match_errors(bad):
    with pytest.raises(AlignmentError, match="BODY_FRAME:HAND_FRAME"):
        parse_match(bad)


@pytest.mark.parametrize("points,msg", [
    ([(10, 20), (5, 30)], "out of order"),
    ([(10, 20), (20, 20)], "out of order"),
    ([(0, 5)], "outside the matrix"),
    ([(10, 99)], "outside the matrix"),
    ([(99, 10)], "outside the matrix"),
    ([(-1, 10)], "outside the matrix"),
    ([(10, 20), (11, 40)], "consecutive body frames"),
    ([(10, 20, -1)], "negative tolerance"),
    ([(10.5, 20)], "integer"),
])
def test_point_errors(points, msg):
    with pytest.raises(AlignmentError, match=msg):
        matching_band(100, 100, 10.0, points)


def test_too_short_or_too_narrow():
    with pytest.raises(AlignmentError, match="too short|too narrow"):
        slanted_band(100, 5, radius=0.3)
    with pytest.raises(AlignmentError, match="positive integer"):
        full_band(0, 5)
    with pytest.raises(AlignmentError, match="exactly one"):
        matching_band(10, 10, None)
    with pytest.raises(AlignmentError, match="non-negative"):
        slanted_band(10, 10, -1.0)
    # a single frame on one side still works (all cells of the one row)
    b = slanted_band(1, 7, 0.5)
    assert (b.lo[0], b.hi[0]) == (0, 6)


def test_band_width_kind_half_and_full():
    """Issue #19 item 11: the paper's "30 % band width" read as the half-width W of eq. 6.3
    (default, as before) or as the full width (W = 15 % n); the full reading covers less of the matrix."""
    from mocomp.splice import SpliceConfig, align_hands, virtual_hand_markers
    from mocomp.splice.synthetic import synthetic_pair

    pair = synthetic_pair(1)
    hb, hh = virtual_hand_markers(pair.body, "right"), virtual_hand_markers(pair.hand, "right")
    n = hb.n_frames
    half = align_hands(hb, hh)
    full = align_hands(hb, hh, band_width_kind="full")
    assert half.pass1.band.width == pytest.approx(0.30 * n) and full.pass1.band.width == pytest.approx(0.15 * n)
    assert half.pass2.band.width == pytest.approx(0.10 * n) and full.pass2.band.width == pytest.approx(0.05 * n)
    assert full.pass1.band.fill < 0.75 * half.pass1.band.fill
    assert SpliceConfig(band_width_kind="full").half_width(0.3, 200) == pytest.approx(30.0)
    # same cells as a half-width band of half the fraction
    same = align_hands(hb, hh, phase_width=0.15, refine_width=0.05)
    np.testing.assert_array_equal(same.pass1.band.lo, full.pass1.band.lo)
    np.testing.assert_array_equal(full.hand_frame, same.hand_frame)
    with pytest.raises(ValueError, match="band_width_kind"):
        SpliceConfig(band_width_kind="quarter")
