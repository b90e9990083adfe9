"""Banded DTW and the two-stage hand/body splice (issue 7, dissertation ch. 6).

Rows:

1. ``banded DTW`` of two random sequences of 60-dim features, 1000 x 1200
   frames, band radius 120 frames (``rho`` of eq. 6.3): ours
   (:func:`mocomp.splice.dtw`: band construction, squared-Euclidean local
   costs on the band, recurrence and the optimal *path*) against
   **dtaidistance** (``dtw_ndim.distance(a, b, window=120, use_c=True)``, C,
   distance only, no path) and **dtw-python** (``dtw(cdist(a, b, 'sqeuclidean'),
   step_pattern=symmetric1, window_type='slantedband', window_size=120)``,
   path included). Goal (issue 7): no slower than dtaidistance (ratio >= 1),
   at both sizes (``--quick``: 300 x 360, 20-dim, radius 36). The note checks
   that the three report the same cost and gives both band sizes:
   dtaidistance's window ``|i - j| < r + |m - n|`` holds ~1.9x the cells of
   the slanted band. The ``equal cells`` row (no goal) runs dtaidistance
   with the window whose cell count is closest to ours: a per-cell
   comparison (a different constraint, so a different cost).
2. ``unconstrained DTW`` of the same sequences against dtw-python (no goal).
3. ``two-stage splice`` of a 569-frame body clip (the paper's "Directions"
   length) with a 472-frame hand clip: virtual markers, both DTW passes with
   their near-optimal tubes and taut frame maps, median merge, blending,
   phase labels and (issue #19) the quality checks on the written arm
   (:func:`mocomp.splice.splice_motions`).
   Peer: the paper's Matlab implementation, 10.95 s (Table 6.3; quoted, not
   run). Goal (issue 7): under 50 ms.
4. ``subsequence DTW`` (issue #19 item 9): open-begin/open-end DTW of a
   360-frame clip inside a 3600-frame take (``--quick``: 90 in 600) on one
   integer cost matrix, against dtw-python's ``asymmetric`` pattern with
   ``open_begin=True, open_end=True`` (same cost, end frame and path). No goal.

Measured here (2 shared cores): banded DTW 2.3-3.0 ms vs dtaidistance
7.9 ms (2.6-3.5x; equal cells 4.1 ms, 1.8x) and dtw-python 39 ms (~17x),
same cost and path as dtw-python; unconstrained 12.7 ms vs 37 ms; the
two-stage splice 16-18 ms (alignment 12-14 ms), error 0.80 frames.
``--quick``: 138 us vs dtaidistance 229 us (1.7x; equal cells 132 us, 1.0x)
and dtw-python 2.4 ms. Of the quick call ~55 us are the local costs, ~50 us
the recurrence with step codes, ~13 us the band, the rest Python glue.
Issue #19 runs: at load average ~1.4 banded DTW 5.0 ms vs dtaidistance
12.4 ms (2.5x) and dtw-python 56 ms (11x); subsequence DTW 3600 x 360
8.3 ms vs dtw-python's open_begin/open_end 55.5 ms (6.7x), same cost, end
frame and path; the two-stage splice 27.8 ms (goal met), of which the quality
checks take ~5 ms (31.3 ms with them, 25.0 ms with ``quality=False``, best of
9). At load 6-8 everything was ~3-4x slower (splice 59-125 ms, subsequence
18 ms vs 99 ms).
"""
from __future__ import annotations

import numpy as np

from timing import best_of, result


def _sequences(quick: bool):
    n, m, d, r = (300, 360, 20, 36) if quick else (1000, 1200, 60, 120)
    rng = np.random.default_rng(0)
    return rng.normal(size=(n, d)), rng.normal(size=(m, d)), r


def _dtai_cells(n: int, m: int, window: int) -> int:
    """Cells dtaidistance evaluates for ``window``: row ``i`` spans columns
    ``max(0, i - max(0, n-m) - window + 1) <= j < min(m, i + max(0, m-n) + window)``
    (its ``|i - j| < window + |n - m|``, from ``dtw.distance``'s loop)."""
    i = np.arange(n)
    start = np.maximum(0, i - max(0, n - m) - window + 1)
    stop = np.minimum(m, i + max(0, m - n) + window)
    return int(np.maximum(stop - start, 0).sum())


def run(quick: bool) -> list[dict]:
    from scipy.spatial.distance import cdist

    from mocomp.splice import dtw, slanted_band, splice_motions
    from mocomp.splice.synthetic import gesture_clip, make_splice_pair, walk_clip

    rows = []
    rep = 15 if quick else 7  # a quick call takes ~0.2 ms: more repeats, a steadier minimum
    a, b, r = _sequences(quick)
    n, m, d = len(a), len(b), a.shape[1]
    dtw(a[:50], b[:60], radius=10)  # compile / load the numba kernels outside the timing
    t_ours, res = best_of(lambda _: dtw(a, b, radius=r), rep)
    band = slanted_band(n, m, radius=r)
    size = f"{n}x{m}, {d}-dim, radius {r}"

    try:
        from dtaidistance import dtw_ndim

        dtw_ndim.distance(a[:50], b[:60], window=10, use_c=True)
        t_dtai, v = best_of(lambda _: dtw_ndim.distance(a, b, window=r, use_c=True), rep)
        rows.append(result(
            f"banded DTW {size}", t_ours, "dtaidistance dtw_ndim.distance(window, use_c=True)", t_dtai,
            goal="ratio >= 1",
            note=f"ours computes more per call: the optimal path, and keeps every band cell's local cost, cumulative "
                 f"cost and step (dtaidistance: the distance only, two rows of memory); ours {band.cells} band cells "
                 f"(|j - i (m-1)/(n-1)| <= {r}), dtaidistance {_dtai_cells(n, m, r)} (its window |i - j| < {r} + |m - n|); "
                 f"same cost here: {res.cost:.6g} vs {v * v:.6g}"))
        # the same number of cells for both (a narrower dtaidistance window; a different constraint, so a
        # different cost): per-cell speed, no goal
        w_eq = min(range(1, r + 1), key=lambda w: abs(_dtai_cells(n, m, w) - band.cells))
        t_eq, _ = best_of(lambda _: dtw_ndim.distance(a, b, window=w_eq, use_c=True), rep)
        rows.append(result(
            f"banded DTW {size}, equal cells", t_ours, f"dtaidistance window={w_eq} ({_dtai_cells(n, m, w_eq)} cells)",
            t_eq, note=f"per-cell comparison: ours {1e9 * t_ours / band.cells:.1f} ns/cell incl. band and path, "
                       f"dtaidistance {1e9 * t_eq / _dtai_cells(n, m, w_eq):.1f} ns/cell"))
    except ImportError:  # pragma: no cover
        rows.append(result(f"banded DTW {size}", t_ours, "dtaidistance (not installed)", None))

    try:
        import dtw as dtwpy

        def peer(_):
            return dtwpy.dtw(cdist(a, b, "sqeuclidean"), step_pattern=dtwpy.symmetric1, window_type="slantedband",
                             window_args={"window_size": r})

        t_py, al = best_of(peer, max(2, rep // 2))
        same = bool(np.array_equal(al.index1, res.path[:, 0]) and np.array_equal(al.index2, res.path[:, 1]))
        rows.append(result(f"banded DTW {size}", t_ours, "dtw-python symmetric1 slantedband (+ cdist)", t_py,
                           note=f"same cost: {np.isclose(al.distance, res.cost)}, same path: {same}"))
        t_full, rf = best_of(lambda _: dtw(a, b), max(2, rep // 2))
        t_pyf, alf = best_of(lambda _: dtwpy.dtw(cdist(a, b, "sqeuclidean"), step_pattern=dtwpy.symmetric1), 2)
        rows.append(result(f"unconstrained DTW {n}x{m}, {d}-dim", t_full, "dtw-python symmetric1 (+ cdist)", t_pyf,
                           note=f"same cost: {np.isclose(alf.distance, rf.cost)}, same path: "
                                f"{bool(np.array_equal(alf.index2, rf.path[:, 1]))}"))
    except ImportError:  # pragma: no cover
        pass

    # subsequence (open-begin/open-end) DTW: where in a long take does a short clip belong (issue #19 item 9)
    from mocomp.splice.subsequence import subsequence_dtw

    ns, ms = (600, 90) if quick else (3600, 360)
    rng = np.random.default_rng(1)
    cs = rng.integers(0, 49, size=(ns, ms)).astype(float)  # sign-metric-like integer costs (eq. 6.6 takes 0..48 per marker set)
    t_sub, rs = best_of(lambda _: subsequence_dtw(cs), rep)
    try:
        import dtw as dtwpy

        t_subpy, ap = best_of(lambda _: dtwpy.dtw(cs.T, step_pattern="asymmetric", open_begin=True, open_end=True),
                              max(2, rep // 3))
        rows.append(result(
            f"subsequence DTW {ns} body x {ms} hand frames", t_sub,
            "dtw-python asymmetric, open_begin=True, open_end=True (same cost matrix)", t_subpy,
            note=f"same cost: {bool(np.isclose(ap.distance, rs.cost))}, same end frame: {ap.jmin == rs.end}, same path: "
                 f"{bool(np.array_equal(ap.index2, rs.path[:, 0]))}; ours a compiled loop over the cells "
                 f"(numba)"))
    except ImportError:  # pragma: no cover
        rows.append(result(f"subsequence DTW {ns} x {ms}", t_sub, "dtw-python (not installed)", None))

    nb = 569
    g = gesture_clip(7, 4)
    pair = make_splice_pair(g.motion, walk_clip(nb, skeleton=g.motion.skeleton), 7, n_body=nb)
    splice_motions(pair.body, pair.hand)  # warm-up
    t_splice, sres = best_of(lambda _: splice_motions(pair.body, pair.hand), max(rep, 7))
    al = sres.alignments["right"]
    rows.append(result(
        f"two-stage splice {nb} body x {pair.hand.n_frames} hand frames", t_splice,
        "paper's Matlab (Table 6.3, 'Directions', quoted)", 10.95, goal="ours_s <= 0.05",
        note=f"procedural gesture on a walk, 30 Hz, taut frame map, with the quality checks of issue #19 "
             f"({1e3 * sres.timings.get('quality', 0):.1f} ms of it); align {1e3 * sres.timings['align']:.1f} ms "
             f"(pass-1 band {al.pass1.band.cells} cells, pass-2 {al.pass2.band.cells}); "
             f"alignment error vs known warp {al.error(pair.truth)['mean']:.2f} frames"))
    return rows


if __name__ == "__main__":  # pragma: no cover
    import sys

    for row in run("--quick" in sys.argv):
        print(row)
