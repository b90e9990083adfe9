"""Which files *are* known clips: the only files the per-clip facts of :mod:`.clips` apply to.

The facts (CMU unit, the 60 Hz of subjects 88/90, the cgspeed T-pose frame, ASE/MASS notes,
...) were checked on particular files. They are read off file names, so they must only be
applied to those files, never to another file that merely shares a name (a motion the
project wrote as ``88_01_x2.bvh`` is in metres at its own rate, and must read back exactly
as written). A file is a known clip when

1. it lives in the data directory (``$MOCOMP_DATA_DIR``): its facts are those of its
   location there (the directory is curated; clips added later are known by location too);
2. it lives in the CMU download cache of :func:`mocomp.datasets.fetch_cmu` under the name
   ``cmu_<trial>.bvh`` that ``fetch_cmu`` gives it; or
3. its SHA-256 equals one that the data directory's ``MANIFEST.md`` lists for a file: it
   is a byte copy of that clip (wherever it lives and whatever it is called), and gets the
   facts of the listed file.

Anything else gets no facts: its reader's own header fps and unit choice apply.

The MANIFEST is parsed leniently, as the data folder grows: ``<64 hex>  <relative path>``
lines (``sha256sum`` output) and Markdown table rows whose first cell is a back-quoted file
path and that have a column headed ``sha256`` (``sha256 of the BVH``; a column of the
``sha256 of the upstream .npy`` is about another file and is ignored). Parsed MANIFESTs
are cached per (path, size, mtime), file hashes per (path, size, mtime).
"""
from __future__ import annotations

import functools
import hashlib
import re
from dataclasses import dataclass
from pathlib import Path

__all__ = ["KnownClip", "identify", "manifest_sha256", "file_sha256"]

_HEX64 = re.compile(r"^[0-9a-f]{64}$")
_SUM_LINE = re.compile(r"^\s*([0-9a-fA-F]{64})\s+\*?(\S.*?)\s*$")


@dataclass(frozen=True)
class KnownClip:
    """A file identified as a known clip.

    Attributes
    ----------
    name: the clip's path relative to the data directory (``flips/cmu_88_01_backflip.bvh``),
        or the cache file name for a downloaded CMU trial; its facts are those of this name.
    how: ``"location"`` (the file is in the data directory / download cache) or
        ``"sha256"`` (its content hash is the MANIFEST's for ``name``).
    """

    name: str
    how: str


def _stat_key(path: Path) -> tuple[str, int, int]:
    st = path.stat()
    return str(path), st.st_size, st.st_mtime_ns


@functools.lru_cache(maxsize=4096)
def _sha256_cached(path: str, size: int, mtime_ns: int) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def file_sha256(path: str | Path) -> str:
    """Hex SHA-256 of a file's bytes, cached per (resolved path, size, mtime)."""
    return _sha256_cached(*_stat_key(Path(path).resolve()))


def _header_cells(line: str) -> list[str]:
    return [c.strip().lower() for c in line.strip().strip("|").split("|")]


def _parse_manifest(text: str) -> dict[str, str]:
    """``sha256 -> relative path`` from MANIFEST text (see the module docstring)."""
    out: dict[str, str] = {}
    sha_col: int | None = None
    in_table = False
    for line in text.splitlines():
        s = line.strip()
        m = _SUM_LINE.match(s)
        if m and not s.startswith("|"):
            rel = m.group(2).strip().strip("`")
            out.setdefault(m.group(1).lower(), rel)
            in_table = False
            continue
        if not s.startswith("|"):
            in_table = False
            sha_col = None
            continue
        cells = [c.strip() for c in s.strip("|").split("|")]
        if not in_table:  # header row of a new table
            in_table = True
            low = _header_cells(s)
            sha_col = next((i for i, c in enumerate(low) if c.startswith("sha256") and "upstream" not in c
                            and ".npy" not in c), None)
            continue
        if sha_col is None or sha_col >= len(cells) or set(cells[0]) <= set("-: "):
            continue
        f = re.match(r"`([^`]+)`", cells[0])
        v = cells[sha_col].strip().strip("`").lower()
        if f and _HEX64.match(v):
            out.setdefault(v, f.group(1).strip())
    return out


@functools.lru_cache(maxsize=16)
def _manifest_cached(path: str, size: int, mtime_ns: int) -> dict[str, str]:
    with open(path, encoding="utf-8", errors="replace") as f:
        return _parse_manifest(f.read())


def manifest_sha256(root: str | Path) -> dict[str, str]:
    """``sha256 -> path relative to root`` for the files ``root/MANIFEST.md`` lists with a hash;
    empty when there is no MANIFEST. Cached per (MANIFEST path, size, mtime)."""
    f = Path(root) / "MANIFEST.md"
    try:
        key = _stat_key(f)
    except OSError:
        return {}
    return dict(_manifest_cached(*key))


def _cache_location(p: Path) -> str | None:
    from .download import cache_dir

    try:
        cache = cache_dir().expanduser().resolve()
    except (ImportError, OSError, RuntimeError):  # no pooch / no cache folder: nothing can be there
        return None
    if p.parent == cache and re.fullmatch(r"cmu_\d{1,3}_\d{2,3}\.bvh", p.name, re.IGNORECASE):
        return p.name
    return None


def identify(path: str | Path, root: str | Path | None = None) -> KnownClip | None:
    """The known clip that file ``path`` is (see the module docstring), or ``None``.

    ``root`` is the data directory (default ``$MOCOMP_DATA_DIR``; without one, only the
    download cache identifies files).
    """
    from .config import data_dir

    p = Path(path).expanduser().resolve()
    r = Path(root).expanduser().resolve() if root is not None else data_dir()
    if r is not None:
        try:
            return KnownClip(p.relative_to(r).as_posix(), "location")
        except ValueError:
            pass
    cached = _cache_location(p)
    if cached is not None:
        return KnownClip(cached, "location")
    if r is not None:
        table = manifest_sha256(r)
        if table:
            try:
                digest = file_sha256(p)
            except OSError:
                return None
            rel = table.get(digest)
            if rel is not None:
                return KnownClip(rel, "sha256")
    return None
