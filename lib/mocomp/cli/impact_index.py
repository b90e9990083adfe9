"""``mocomp impact-index DIR``: build or refresh the reaction-library index of the impact search.

Per clip: frames (its own and at the index rate), unique frames (dissertation eq. 4.2, tolerance
``T``), the time taken and whether it came from the cache; then the refused files with the reason
(unreadable, or a skeleton that cannot be mapped onto the victim's). The index is cached per clip,
content-addressed (:mod:`mocomp.impact.index`): a changed clip is rebuilt, the others are read back.
"""
from __future__ import annotations

import json
import sys
from collections import Counter
from pathlib import Path


def register(sub) -> None:
    from ._common import float_in, positive_float

    p = sub.add_parser(
        "impact-index", help="build/refresh the reaction-library index of the impact search (unique frames, cached)",
        description="Index a folder of reaction clips for `mocomp impact`: every clip is brought onto the victim's "
                    "skeleton (retargeted by joint-name mapping, or refused with the reason), its body-part features "
                    "and unique frames (dissertation eq. 4.2, tolerance T) are computed and cached by content. "
                    "Prints per clip the frames, unique frames and time.")
    p.add_argument("library", metavar="DIR", help="folder of reaction clips (.bvh, .amc, DeepMimic .txt), searched recursively")
    p.add_argument("--cache", metavar="DIR", default=None,
                   help="cache folder (default: $MOCOMP_CACHE_DIR/impact_index or the user's cache folder)")
    p.add_argument("--tolerance", metavar="T", type=float_in(0.0), default=0.5,
                   help="unique-frame tolerance T of eq. 4.2 (default 0.5, the dissertation's Appendix A)")
    p.add_argument("--victim", metavar="FILE", default=None,
                   help="a motion on the victim's skeleton (default: the skeleton of most library frames)")
    p.add_argument("--fps", metavar="HZ", type=positive_float, default=30.0,
                   help="index rate; clips whose rate differs by more than 2%% are resampled (default 30)")
    p.add_argument("--json", metavar="FILE", default=None, help="also write the per-clip table as JSON")
    p.set_defaults(func=run)


def _majority_skeleton(directory: Path):
    """The skeleton carrying the most frames among the readable clips below ``directory``."""
    import warnings

    from .. import io
    from ..errors import MocompError
    from ..impact.index import LibraryError, library_files

    count: Counter = Counter()
    skeletons = {}
    for f in library_files(directory):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                m = io.load(f)
        except (MocompError, ValueError, OSError):
            continue
        key = hash(m.skeleton)
        skeletons.setdefault(key, m.skeleton)
        count[key] += m.n_frames
    if not count:
        raise LibraryError(f"{directory}: no readable motion file (.bvh, .amc, .txt, .json) in the library")
    return skeletons[count.most_common(1)[0][0]]


def run(args) -> int:
    from .. import io
    from ..impact.index import build_index

    directory = Path(args.library)
    skeleton = io.load(args.victim).skeleton if args.victim else _majority_skeleton(directory)
    index = build_index(directory, skeleton, cache_dir=args.cache, tolerance=args.tolerance, progress=False,
                        fps=args.fps)
    rows = []
    w = max(len(c.name) for c in index.clips)
    print(f"{'clip':<{w}}  {'frames':>6}  {'@' + format(index.fps, 'g') + ' Hz':>8}  {'unique':>6}  {'ratio':>6}  "
          f"{'ms':>7}  source")
    for c in index.clips:
        ratio = c.n_frames / c.unique.size
        print(f"{c.name:<{w}}  {c.native_frames:>6}  {c.n_frames:>8}  {c.unique.size:>6}  {ratio:>6.1f}  "
              f"{c.seconds * 1e3:>7.1f}  {'cache' if c.cached else 'built'}")
        rows.append({"clip": c.name, "frames": c.native_frames, "index_frames": c.n_frames, "unique": int(c.unique.size),
                     "seconds": c.seconds, "cached": c.cached, "notes": list(c.notes)})
    print(f"{'total':<{w}}  {sum(c.native_frames for c in index.clips):>6}  {index.n_frames:>8}  {index.n_unique:>6}  "
          f"{index.n_frames / index.n_unique:>6.1f}  {index.seconds * 1e3:>7.1f}  "
          f"T = {index.tolerance:g}, {len(index.clips)} clips, skeleton {skeleton.n_joints} joints "
          f"(root {skeleton.names[0]!r}), cache {index.cache_dir}")
    for path, reason in index.refused:
        print(f"refused: {reason}", file=sys.stderr)
    if args.json:
        Path(args.json).write_text(json.dumps({"library": str(directory), "tolerance": index.tolerance, "fps": index.fps,
                                               "cache": index.cache_dir, "seconds": index.seconds, "clips": rows,
                                               "refused": [{"path": p, "reason": r} for p, r in index.refused]},
                                              indent=2))
    return 0
