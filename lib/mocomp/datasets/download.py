"""Fetch CMU trials that are not in the data directory into a local cache (pooch).

The registry lists, for each trial the data MANIFEST names ("CMU trials not
staged"), the repository, commit and path of a public copy of the cgspeed BVH
release. URLs pin the commit, so what a host serves for a URL should not change.

Integrity -- **trust on first use**, not a pinned checksum:

* where the MANIFEST states a file size (88_01, 88_05, 90_08, 83_58, 85_02,
  141_16), the download must have exactly that many bytes, else it is deleted
  and :class:`~mocomp.errors.ChecksumError` raised;
* no SHA-256 is pinned here. The data MANIFEST's SHA-256 list covers only the
  files staged in the data directory, and the five CMU files among them were
  rebuilt from a code index's text (their carriage returns may sit differently
  from the upstream bytes), so their hashes are not those of the files served
  at these URLs; no other trial has a known hash. The first download of a trial
  is therefore accepted as it comes (beyond the size check): whatever a mirror or
  a man in the middle serves the first time is what gets recorded;
* its SHA-256 is then recorded in ``registry.json`` in the cache and checked by
  pooch on every later fetch, so a file that changes afterwards (in the cache
  or on the host) is refused;
* a caller who knows the hash passes ``known_hash="sha256:..."`` to
  :func:`fetch_cmu`, which then checks the very first download too.

Nothing here runs unless asked: :func:`fetch_cmu` is explicit, and
``mocomp.datasets.load(..., download=True)`` opts in. The cache is
``$MOCOMP_CACHE_DIR`` or the platform cache folder (``pooch.os_cache("mocomp")``).
"""
from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

from ..errors import ChecksumError, DataNotFoundError

__all__ = ["CMU_REGISTRY", "CmuLocation", "fetch_cmu", "cache_dir", "url_for", "CACHE_ENV", "URL_ENV"]

#: environment variable naming the download cache folder
CACHE_ENV = "MOCOMP_CACHE_DIR"
#: environment variable overriding the URL template (``{repo}``, ``{commit}``, ``{path}``), e.g. a mirror
URL_ENV = "MOCOMP_CMU_URL"
DEFAULT_URL = "https://raw.githubusercontent.com/{repo}/{commit}/{path}"

_UNA = "una-dinosauria/cmu-mocap"
_A = "5d98bb6b62b4735d89ff5f53e96899de2b92d8b4"  # data/0NN/...
_B = "62ac0fb0ec43cff2bf66426928f4fa6682d4bbdc"  # 0NN/...
_C = "f50fdd380214418ff240056a728a34adaf7bd1b0"  # NN/..., 1NN/...
_D = "1eb6cbdd0db2ae3f8ae76c8f39c9282b90ebe635"  # cmuconvert-mb2-*/...
_RB = ("RobertBiehl/cmu-mocap", "96efe0bb1bf90346ebce2f5bd9dc7d2d00f474bc")


@dataclass(frozen=True)
class CmuLocation:
    """Where a CMU trial's BVH lives: ``repo`` @ ``commit`` : ``path``; ``size`` in bytes when known."""

    trial: str
    description: str
    repo: str
    commit: str
    path: str
    size: int | None = None


def _reg(entries) -> dict[str, CmuLocation]:
    out = {}
    for trial, desc, where, path, *size in entries:
        repo, commit = (_UNA, where) if isinstance(where, str) else where
        out[trial] = CmuLocation(trial, desc, repo, commit, path, size[0] if size else None)
    return out


#: trial id -> location, from the data MANIFEST ("CMU trials not staged").
CMU_REGISTRY: dict[str, CmuLocation] = _reg([
    ("88_01", "backflip", _A, "data/088/88_01.bvh", 158_001),
    ("87_03", "Backflip", _A, "data/087/87_03.bvh"),
    ("87_04", "backflip", _D, "cmuconvert-mb2-86-94/87/87_04.bvh"),
    ("88_05", "cartwheel into backflip", _C, "88/88_05.bvh", 118_283),
    ("88_08", "crouch and flip backward on hands", _D, "cmuconvert-mb2-86-94/88/88_08.bvh"),
    ("90_08", "side flip", _C, "90/90_08.bvh", 256_982),
    ("90_13", "bck flp twst fall", _A, "data/090/90_13.bvh"),
    ("90_19", "monkey backflip", _D, "cmuconvert-mb2-86-94/90/90_19.bvh"),
    ("89_03", "flip and stand on one hand", _D, "cmuconvert-mb2-86-94/89/89_03.bvh"),
    ("89_04", "spins, flips", _D, "cmuconvert-mb2-86-94/89/89_04.bvh"),
    ("89_05", "spin upside down, handstand, flips", _D, "cmuconvert-mb2-86-94/89/89_05.bvh"),
    ("85_06", "KickFlip", _D, "cmuconvert-mb2-81-85/85/85_06.bvh"),
    ("85_07", "KickFlipStumble", _D, "cmuconvert-mb2-81-85/85/85_07.bvh"),
    ("90_09", "Flip forward onto hands and back again", _A, "data/090/90_09.bvh"),
    ("90_11", "hand spring", _RB, "data/090/90_11.bvh"),
    ("49_06", "cartwheel", _B, "049/49_06.bvh"),
    ("49_08", "cartwheels", _C, "49/49_08.bvh"),
    ("90_02", "cartwheel", _A, "data/090/90_02.bvh"),
    ("90_03", "cartwheel", _C, "90/90_03.bvh"),
    ("88_07", "cartwheel", _C, "88/88_07.bvh"),
    ("87_05", "cartwheels", _C, "87/87_05.bvh"),
    ("144_01", "Cartwheels", _D, "cmuconvert-mb2-141-144/144/144_01.bvh"),
    ("144_02", "Cartwheels", _C, "144/144_02.bvh"),
    ("85_01", "JumpTwist", _D, "cmuconvert-mb2-81-85/85/85_01.bvh"),
    ("85_02", "JumpTwist", _D, "cmuconvert-mb2-81-85/85/85_02.bvh", 621_014),
    ("83_54", "hop turn 180 left in air", _D, "cmuconvert-mb2-81-85/83/83_54.bvh"),
    ("83_56", "hop turn 180 left in air", _A, "data/083/83_56.bvh"),
    ("83_58", "hop turn left 270 in air", _D, "cmuconvert-mb2-81-85/83/83_58.bvh", 280_167),
    ("83_59", "hop turn left 270 in air", _D, "cmuconvert-mb2-81-85/83/83_59.bvh"),
    ("83_60", "hop turn left 270 in air", _D, "cmuconvert-mb2-81-85/83/83_60.bvh"),
    ("83_64", "hop and turn right 360 in air", _B, "083/83_64.bvh"),
    ("83_65", "hop and turn right 360 in air", _A, "data/083/83_65.bvh"),
    ("91_54", "180 (jump twist)", _A, "data/091/91_54.bvh"),
    ("91_59", "360 smallStumble (jump twist)", _D, "cmuconvert-mb2-86-94/91/91_59.bvh"),
    ("91_61", "360 (jump twist)", _B, "091/91_61.bvh"),
    ("75_06", "180 jump", _D, "cmuconvert-mb2-60-75/75/75_06.bvh"),
    ("75_07", "angle jumps", _D, "cmuconvert-mb2-60-75/75/75_07.bvh"),
    ("75_08", "360 jumps", _D, "cmuconvert-mb2-60-75/75/75_08.bvh"),
    ("141_06", "Jump Twist", _D, "cmuconvert-mb2-141-144/141/141_06.bvh"),
    ("141_16", "wave hello", _RB, "data/141/141_16.bvh", 233_582),
    ("143_08", "Jumping Twists", _A, "data/143/143_08.bvh"),
    ("143_09", "Jumping Twists", _A, "data/143/143_09.bvh"),
    ("127_24", "Run Dive Over Roll Run", _A, "data/127/127_24.bvh"),
    ("128_10", "Run Dive Over Roll Run", _C, "128/128_10.bvh"),
    ("128_11", "Run Dive Over Roll Run", _C, "128/128_11.bvh"),
    ("16_06", "forward jump", _A, "data/016/16_06.bvh"),
    ("91_42", "JumpForward", _B, "091/91_42.bvh"),
    ("143_06", "Jumping Heights", _A, "data/143/143_06.bvh"),
    ("75_01", "run jump", _D, "cmuconvert-mb2-60-75/75/75_01.bvh"),
    ("118_01", "Jump", _A, "data/118/118_01.bvh"),
    ("86_01", "jumps kicks and punches", _D, "cmuconvert-mb2-86-94/86/86_01.bvh"),
    ("87_01", "Jump with kick and spin", _D, "cmuconvert-mb2-86-94/87/87_01.bvh"),
    ("88_06", "jump and spin kick", _D, "cmuconvert-mb2-86-94/88/88_06.bvh"),
    ("90_05", "jump kick", _D, "cmuconvert-mb2-86-94/90/90_05.bvh"),
    ("90_07", "jump kick", _D, "cmuconvert-mb2-86-94/90/90_07.bvh"),
    ("75_16", "jump kick", _D, "cmuconvert-mb2-60-75/75/75_16.bvh"),
    ("135_04", "Front Kick", _D, "cmuconvert-mb2-131-135/135/135_04.bvh"),
    ("135_07", "Mawashigeri", _D, "cmuconvert-mb2-131-135/135/135_07.bvh"),
    ("135_09", "Oiduki", _C, "135/135_09.bvh"),
    ("135_11", "Yokogeri", _A, "data/135/135_11.bvh"),
    ("143_23", "Punching", _A, "data/143/143_23.bvh"),
    ("143_24", "Kicking", _C, "143/143_24.bvh"),
    ("144_05", "Front_Kicking", _C, "144/144_05.bvh"),
    ("144_13", "Left_Punch_Sequence001", _A, "data/144/144_13.bvh"),
    ("144_20", "Punch_Sequence", _D, "cmuconvert-mb2-141-144/144/144_20.bvh"),
    ("144_21", "Punch_Sequence", _D, "cmuconvert-mb2-141-144/144/144_21.bvh"),
    ("16_21", "walk", _A, "data/016/16_21.bvh"),
    ("16_18", "walk, 90-degree left turn", _A, "data/016/16_18.bvh"),
    ("16_23", "walk, veer left", _B, "016/16_23.bvh"),
    ("16_27", "walk, 90-degree left turn", _B, "016/16_27.bvh"),
    ("16_35", "run/jog", _A, "data/016/16_35.bvh"),
    ("127_04", "Walk to Run", _C, "127/127_04.bvh"),
    ("143_03", "Start to Run", _C, "143/143_03.bvh"),
    ("69_28", "walk forward, 90-degree smooth turn", _D, "cmuconvert-mb2-60-75/69/69_28.bvh"),
    ("69_29", "walk forward, 90-degree smooth turn", _D, "cmuconvert-mb2-60-75/69/69_29.bvh"),
    ("69_30", "walk forward, 90-degree smooth turn", _D, "cmuconvert-mb2-60-75/69/69_30.bvh"),
    ("69_31", "walk forward, 90-degree smooth turn", _D, "cmuconvert-mb2-60-75/69/69_31.bvh"),
    ("69_33", "walk forward, 90-degree smooth turn", _D, "cmuconvert-mb2-60-75/69/69_33.bvh"),
])


def normalize_trial(trial: str) -> str:
    """``"088_1"``/``"88_01"`` -> ``"88_01"`` (subject without, trial with a leading zero)."""
    parts = str(trial).strip().split("_")
    if len(parts) != 2 or not all(p.isdigit() for p in parts):
        raise ValueError(f"{trial!r} is not a CMU trial id like '88_01'")
    return f"{int(parts[0])}_{int(parts[1]):02d}"


def cache_dir() -> Path:
    """The download cache: ``$MOCOMP_CACHE_DIR`` or pooch's per-user cache for mocomp."""
    import pooch

    value = os.environ.get(CACHE_ENV)
    return Path(value).expanduser() if value else Path(pooch.os_cache("mocomp"))


def url_for(loc: CmuLocation, template: str | None = None) -> str:
    template = template or os.environ.get(URL_ENV) or DEFAULT_URL
    return template.format(repo=loc.repo, commit=loc.commit, path=loc.path)


def _hashes_file(cache: Path) -> Path:
    return cache / "registry.json"


def _read_hashes(cache: Path) -> dict[str, str]:
    f = _hashes_file(cache)
    if not f.is_file():
        return {}
    try:
        return dict(json.loads(f.read_text()))
    except (ValueError, TypeError) as e:
        raise ChecksumError(f"{f}: recorded checksums are unreadable ({e}); delete the file to re-record") from None


def fetch_cmu(trial: str, cache: str | Path | None = None, url_template: str | None = None,
              known_hash: str | None = None, progressbar: bool = False) -> Path:
    """Download CMU ``trial`` (e.g. ``"87_03"``) into the cache and return its path.

    A file already in the cache with its recorded SHA-256 is returned without
    network access. The first download is trusted as served (trust on first use:
    only its size is checked, where the registry knows it, unless ``known_hash``
    is given); its SHA-256 is recorded and every later fetch must match it.
    ``url_template`` (or ``$MOCOMP_CMU_URL``) points at a mirror: ``"{repo}"``,
    ``"{commit}"`` and ``"{path}"`` are filled in from the registry.
    Raises :class:`DataNotFoundError` for an unknown trial or a failed download
    and :class:`ChecksumError` when the bytes do not match the known size/hash.
    """
    import pooch

    tid = normalize_trial(trial)
    loc = CMU_REGISTRY.get(tid)
    if loc is None:
        raise DataNotFoundError(
            f"CMU trial {tid} is not in the download registry (mocomp.datasets.download.CMU_REGISTRY lists "
            f"{len(CMU_REGISTRY)} trials); get it from mocap.cs.cmu.edu and put it in the data directory")
    cache = Path(cache) if cache is not None else cache_dir()
    cache.mkdir(parents=True, exist_ok=True)
    hashes = _read_hashes(cache)
    expected = known_hash or hashes.get(tid)
    fname = f"cmu_{tid}.bvh"
    url = url_for(loc, url_template)
    try:
        path = Path(pooch.retrieve(url, known_hash=expected, fname=fname, path=cache, progressbar=progressbar))
    except ValueError as e:  # pooch: hash mismatch
        raise ChecksumError(f"CMU {tid} from {url}: {e}") from None
    except Exception as e:  # requests/urllib errors: no network, 404, ...
        raise DataNotFoundError(f"could not download CMU {tid} from {url}: {type(e).__name__}: {e}") from None
    if loc.size is not None and path.stat().st_size != loc.size:
        size = path.stat().st_size
        path.unlink()
        raise ChecksumError(f"CMU {tid} from {url}: {size} bytes, the registry says {loc.size}; file removed")
    digest = "sha256:" + pooch.file_hash(str(path), alg="sha256")
    if hashes.get(tid) != digest:
        hashes[tid] = digest
        _hashes_file(cache).write_text(json.dumps(hashes, indent=1, sort_keys=True) + "\n")
    return path
