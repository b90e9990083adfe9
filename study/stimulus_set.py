"""A rendered stimulus set, read from its manifest CSV.

The renderer (``mocomp study render SPEC -o DIR``) writes one manifest row per
stimulus with the columns in :data:`MANIFEST_COLUMNS`; video and poster paths
are relative to the manifest's folder. The trial design, the harness and the
analysis only ever see a :class:`StimulusSet`, so a hand-made manifest (e.g.
pilot videos, or :func:`study.placeholders.make_placeholder_set`) works the
same way.

The *stimulus-set id* is a short hash of the sorted ``(stimulus_id, sha256)``
pairs: two sessions share it exactly when they showed the same videos, which
the analysis uses to refuse mixing responses to different stimulus sets.
"""
from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from mocomp.errors import StudyDataError

#: Columns every manifest must have (extra columns are kept and ignored).
MANIFEST_COLUMNS: tuple[str, ...] = (
    "stimulus_id", "base_clip", "perturbation", "direction", "nominal_level",
    "achieved_error", "duration_s", "file", "poster", "sha256",
)
#: Allowed values of ``perturbation``; ``none`` marks the unperturbed (correct) motions.
PERTURBATIONS: tuple[str, ...] = ("none", "am_abrupt", "am_smooth", "takeoff")
#: Allowed values of ``direction``.
DIRECTIONS: tuple[str, ...] = ("increase", "decrease", "none")


def sha256_file(path: str | Path, chunk: int = 1 << 20) -> str:
    """Hex SHA-256 of a file's bytes."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(chunk), b""):
            h.update(block)
    return h.hexdigest()


@dataclass(frozen=True)
class StimulusSet:
    """The stimuli of one study, as listed by a manifest.

    Attributes
    ----------
    path:
        The manifest CSV.
    table:
        One row per stimulus, indexed by ``stimulus_id``; columns
        :data:`MANIFEST_COLUMNS` (``nominal_level`` in the renderer's units,
        e.g. percent, 0 for unperturbed motions) plus ``condition``
        (``"perturbation/direction/level"``, ``"none"`` for unperturbed).
    set_id:
        16 hex digits identifying the set's content (see module docstring).
    manifest_sha256:
        SHA-256 of the manifest file itself.
    """

    path: Path
    table: pd.DataFrame
    set_id: str
    manifest_sha256: str

    @property
    def root(self) -> Path:
        """Folder that relative ``file`` / ``poster`` paths are resolved against."""
        return self.path.parent

    @property
    def ids(self) -> list[str]:
        return list(self.table.index)

    def video_path(self, stimulus_id: str) -> Path:
        return self.root / str(self.table.at[stimulus_id, "file"])

    def poster_path(self, stimulus_id: str) -> Path | None:
        p = self.table.at[stimulus_id, "poster"]
        return None if not isinstance(p, str) or not p else self.root / p

    def row(self, stimulus_id: str) -> dict:
        if stimulus_id not in self.table.index:
            raise StudyDataError(f"unknown stimulus_id {stimulus_id!r}", self.path, column="stimulus_id")
        d = self.table.loc[stimulus_id].to_dict()
        d["stimulus_id"] = stimulus_id
        return d

    def verify_videos(self) -> None:
        """Recompute every video's SHA-256 and compare it with the manifest's ``sha256``.

        Raises :class:`~mocomp.errors.StudyDataError` naming the manifest, its
        line, the column and the video (missing or changed since rendering).
        :meth:`study.session.Session.open` calls it before a session starts or
        resumes, so a participant never sees a video other than the recorded one.
        """
        for pos, (sid, r) in enumerate(self.table.iterrows()):
            f = self.root / str(r["file"])
            if not f.is_file():
                raise StudyDataError(f"video file {f} of stimulus {sid!r} does not exist", self.path, pos + 2, "file")
            if sha256_file(f) != str(r["sha256"]).lower():
                raise StudyDataError(f"SHA-256 of {f} (stimulus {sid!r}) differs from the manifest: the video "
                                     "changed after rendering; re-render (mocomp study render) or restore it",
                                     self.path, pos + 2, "sha256")

    @property
    def unperturbed(self) -> list[str]:
        return list(self.table.index[self.table["perturbation"] == "none"])

    @property
    def perturbed(self) -> list[str]:
        return list(self.table.index[self.table["perturbation"] != "none"])


def condition_label(perturbation: str, direction: str, level: float) -> str:
    """Canonical condition key, e.g. ``"am_abrupt/increase/25"``; ``"none"`` for controls."""
    if perturbation == "none":
        return "none"
    lv = float(level)
    lvs = str(int(lv)) if lv.is_integer() else f"{lv:g}"
    return f"{perturbation}/{direction}/{lvs}"


def _set_id(table: pd.DataFrame) -> str:
    h = hashlib.sha256()
    for sid, sha in sorted(zip(table.index, table["sha256"])):
        h.update(f"{sid}\t{sha}\n".encode())
    return h.hexdigest()[:16]


#: The audit columns ``mocomp study render`` writes (study/DATA_DICTIONARY.md). Optional: a manifest
#: without them (older renders, hand-made sets) loads; when present their values are checked.
AUDIT_VERDICTS: tuple[str, ...] = ("pass", "fail")
AUDIT_COUNT_COLUMNS: tuple[str, ...] = ("audit_violations", "audit_advisories", "audit_new_violations",
                                        "audit_source_violations")


def _check_audit_columns(df: pd.DataFrame, path: Path, line) -> None:
    for col in ("audit_verdict", "audit_source_verdict"):
        if col in df.columns:
            v = df[col]
            bad = v.notna() & ~v.astype(str).isin(AUDIT_VERDICTS)
            if bad.any():
                i = int(df.index[bad][0])
                raise StudyDataError(f"{v[i]!r} is not one of {', '.join(AUDIT_VERDICTS)}", path, line(i), col)
    for col in AUDIT_COUNT_COLUMNS:
        if col in df.columns:
            v = pd.to_numeric(df[col], errors="coerce")
            bad = df[col].notna() & ~(v.notna() & (v >= 0) & (v == v.round()))
            if bad.any():
                i = int(df.index[bad][0])
                raise StudyDataError(f"{df.at[i, col]!r} is not a count (a whole number >= 0)", path, line(i), col)


def load_manifest(path: str | Path, *, check_files: bool = True, verify_hashes: bool = False) -> StimulusSet:
    """Read and validate a manifest CSV.

    Parameters
    ----------
    path:
        The manifest CSV.
    check_files:
        Require every ``file`` to exist (``poster`` may be empty).
    verify_hashes:
        Recompute each video's SHA-256 and compare with the ``sha256`` column.

    Raises
    ------
    StudyDataError
        Missing columns, duplicate ids, unknown perturbation/direction values,
        non-numeric or negative levels, missing files, hash mismatches; the
        message names the file, the CSV line and the column.
    FileNotFoundError
        The manifest does not exist.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"stimulus manifest not found: {path}")
    try:
        df = pd.read_csv(path, dtype={"stimulus_id": str, "base_clip": str, "perturbation": str,
                                      "direction": str, "file": str, "poster": str, "sha256": str},
                         keep_default_na=False, na_values=[""])
    except pd.errors.EmptyDataError:
        raise StudyDataError("manifest is empty (no header)", path) from None
    missing = [c for c in MANIFEST_COLUMNS if c not in df.columns]
    if missing:
        raise StudyDataError(f"manifest lacks column(s) {', '.join(missing)}; "
                             f"expected {', '.join(MANIFEST_COLUMNS)}", path, line=1)
    if len(df) == 0:
        raise StudyDataError("manifest has a header but no stimuli", path)
    line = lambda i: int(i) + 2  # noqa: E731  (header is line 1)
    for col in ("stimulus_id", "perturbation", "direction", "file", "sha256"):
        bad = df.index[df[col].isna()]
        if len(bad):
            raise StudyDataError("empty value", path, line(bad[0]), col)
    dup = df["stimulus_id"].duplicated(keep="first")
    if dup.any():
        i = int(df.index[dup][0])
        raise StudyDataError(f"duplicate stimulus_id {df.at[i, 'stimulus_id']!r}", path, line(i), "stimulus_id")
    for col, allowed in (("perturbation", PERTURBATIONS), ("direction", DIRECTIONS)):
        bad = ~df[col].isin(allowed)
        if bad.any():
            i = int(df.index[bad][0])
            raise StudyDataError(f"{df.at[i, col]!r} is not one of {', '.join(allowed)}", path, line(i), col)
    for col in ("nominal_level", "achieved_error", "duration_s"):
        vals = pd.to_numeric(df[col], errors="coerce")
        bad = vals.isna() & df[col].notna()
        if bad.any():
            i = int(df.index[bad][0])
            raise StudyDataError(f"not a number: {df.at[i, col]!r}", path, line(i), col)
        df[col] = vals.astype(float)
    _check_audit_columns(df, path, line)
    for i, r in df.iterrows():
        lv = r["nominal_level"]
        if not math.isfinite(lv) or lv < 0:
            raise StudyDataError(f"nominal_level must be a finite number >= 0, got {lv}", path, line(i), "nominal_level")
        if (r["perturbation"] == "none") != (r["direction"] == "none"):
            raise StudyDataError(f"perturbation {r['perturbation']!r} with direction {r['direction']!r}: "
                                 "direction is 'none' exactly for unperturbed motions", path, line(i), "direction")
        if r["perturbation"] == "none" and lv != 0:
            raise StudyDataError(f"unperturbed motion with nominal_level {lv} (must be 0)", path, line(i), "nominal_level")
        if r["perturbation"] != "none" and lv == 0:
            raise StudyDataError("perturbed motion with nominal_level 0", path, line(i), "nominal_level")
        if not (isinstance(r["duration_s"], float) and r["duration_s"] > 0):
            raise StudyDataError(f"duration_s must be > 0, got {r['duration_s']}", path, line(i), "duration_s")
        if check_files or verify_hashes:
            f = path.parent / r["file"]
            if not f.is_file():
                raise StudyDataError(f"video file {f} does not exist", path, line(i), "file")
            if verify_hashes and sha256_file(f) != str(r["sha256"]).lower():
                raise StudyDataError(f"SHA-256 of {f} differs from the manifest (file changed after rendering?)",
                                     path, line(i), "sha256")
    df["base_clip"] = df["base_clip"].fillna("")
    df["poster"] = df["poster"].fillna("")
    df["sha256"] = df["sha256"].str.lower()
    df["condition"] = [condition_label(p, d, lv) for p, d, lv in
                       zip(df["perturbation"], df["direction"], df["nominal_level"])]
    table = df.set_index("stimulus_id", drop=True)
    return StimulusSet(path=path.resolve(), table=table, set_id=_set_id(table), manifest_sha256=sha256_file(path))
