#!/usr/bin/env python
"""Write the figures the README shows to ``docs/figures/`` (embedded data only).

Each figure is made by the library from the embedded, generated data, so anyone
can rebuild it and check it against the README:

* ``double_backflip.png`` and ``double_backflip_momentum.png``: ``mocomp demo``'s
  filmstrip (flips paper Fig. 4a: original yellow, double flip turquoise) and its
  angular/linear momentum before and after;
* ``splice_bands.png``: dissertation Fig. 6.3 on a synthetic ground-truth pair, the
  slanted band of eq. 6.3 with the optimal path and the known warp, and the band
  reshaped by two user matching points (eq. 6.4-6.5);
* ``table2_dprime.png``: flips paper Table 2, the sensitivities computed from the
  published mean ratings against the published d'.

Usage::

    python scripts/write_readme_figures.py            # writes docs/figures/*.png
    python scripts/write_readme_figures.py --out DIR
"""
from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def double_flip(out: Path) -> list[Path]:
    from mocomp.flips import demo

    with tempfile.TemporaryDirectory() as tmp:
        demo(tmp, flips=2, verbose=False)
        shutil.copy(Path(tmp) / "filmstrip.png", out / "double_backflip.png")
        shutil.copy(Path(tmp) / "momentum.png", out / "double_backflip_momentum.png")
    return [out / "double_backflip.png", out / "double_backflip_momentum.png"]


def splice_bands(out: Path) -> Path:
    from mocomp.plots.dtw import plot_band
    from mocomp.splice import align_hands, virtual_hand_markers
    from mocomp.splice.synthetic import synthetic_pair

    pair = synthetic_pair(0)
    body = virtual_hand_markers(pair.body, pair.side)
    hand = virtual_hand_markers(pair.hand, pair.side)
    auto = align_hands(body, hand)
    x1, x2 = auto.n // 3, 2 * auto.n // 3
    points = [(x1, int(round(pair.truth[x1])), 0), (x2, int(round(pair.truth[x2])), 4)]
    pinned = align_hands(body, hand, points=points, phase_width=0.08)
    err = auto.error(pair.truth)["mean"]
    fig, axs = plt.subplots(1, 2, figsize=(11, 4.8))
    plot_band(auto.pass1, axs[0], truth=pair.truth,
              title=f"slanted band (eq. 6.3), no user input: error {err:.2f} frames")
    plot_band(pinned.pass1, axs[1], truth=pair.truth,
              title=f"band through 2 user points (eq. 6.4-6.5): {pinned.error(pair.truth)['mean']:.2f} frames")
    fig.tight_layout()
    path = out / "splice_bands.png"
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


def table2(out: Path) -> Path:
    from study.paper import reproduce_table2

    cells, _ = reproduce_table2()
    half = 0.5 * 10.0 ** (-cells["decimals"])
    fig, ax = plt.subplots(figsize=(5, 4.4))
    ax.errorbar(cells["dprime_published"], cells["dprime_ours"], xerr=half, fmt="o", ms=4)
    lim = [-0.7, 1.5]
    ax.plot(lim, lim, "k:", lw=1)
    ax.set_xlabel("published d' (bars: printed precision)")
    ax.set_ylabel("ours, z(r0) - z(r) from the printed ratings")
    ax.set_title(f"Table 2: {int(cells['consistent'].sum())} of {len(cells)} cells match within rounding",
                 fontsize=10)
    fig.tight_layout()
    path = out / "table2_dprime.png"
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description="Write the README's figures to docs/figures/ from embedded data.")
    ap.add_argument("--out", type=Path, default=ROOT / "docs" / "figures", help="output folder")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    written = [*double_flip(args.out), splice_bands(args.out), table2(args.out)]
    for p in written:
        print(f"wrote {p} ({p.stat().st_size // 1024} KiB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
