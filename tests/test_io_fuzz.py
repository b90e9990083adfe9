"""Property-based fuzzing of every reader (issue 12): a mutated file -- byte flips,
deleted/duplicated/swapped lines, huge/NaN/inf/denormal/5001-digit numbers, wrong
counts, unicode digits, CRLF/CR line ends, truncation, deep nesting -- either reads
into a value whose every number is finite and plausible (``mocomp.io.validate``:
1-10,000 Hz, lengths within +-1e4 m, forward-kinematics positions finite) or raises
MotionFormatError naming the file. Anything else fails: another exception, a hang
(> 20 s) or a crash.

The readers run in a child process (one per test, reused across examples), so that a
segfault inside ezc3d (C3D) or a compiled kernel fails the example instead of taking
pytest down, and a hang is caught by a timeout. Seeds are small synthetic files plus,
when the data directory is set (mandatory under CI), cut-down real clips.
Example budget: 150 per format under CI (derandomized, tests/conftest.py), 40 locally.
"""
from __future__ import annotations

import json
import re
import select
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from conftest import IN_CI
from mocomp.datasets import data_dir

MAX_EXAMPLES = 150 if IN_CI else 40
FUZZ = settings(max_examples=MAX_EXAMPLES, deadline=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                       HealthCheck.function_scoped_fixture])

# ------------------------------------------------------------------ the reader process
_WORKER = r'''
import json, sys, warnings
import numpy as np
warnings.simplefilter("ignore")
from mocomp.errors import MotionFormatError
from mocomp.io import read_amc, read_bvh, read_c3d, read_deepmimic
FPS_RANGE, MAX_LENGTH_M = (1.0, 10000.0), 1e4  # mocomp.io.validate's ranges, stated here independently

def plausible(v):
    lo, hi = FPS_RANGE
    if not (lo <= v.fps <= hi):
        return f"fps {v.fps}"
    if hasattr(v, "skeleton"):
        arrays = {"root_positions": v.root_positions, "rotations": v.rotations, "offsets": v.skeleton.offsets,
                  "positions": v.positions}
    else:
        arrays = {"markers": v.positions[v.mask]}
    for k, a in arrays.items():
        if not np.all(np.isfinite(a)):
            return f"{k} not finite"
        if k != "rotations" and k != "positions" and a.size and np.abs(a).max() > MAX_LENGTH_M:
            return f"{k} up to {np.abs(a).max():.3g} m"
    return None

for line in sys.stdin:
    fmt, path, extra = json.loads(line)
    try:
        if fmt == "bvh":
            v = read_bvh(path)
        elif fmt == "amc":
            v = read_amc(path, asf=extra)
        elif fmt == "asf":
            v = read_amc(extra, asf=path)
        elif fmt == "deepmimic":
            v = read_deepmimic(path, character=extra)
        elif fmt == "character":
            v = read_deepmimic(extra, character=path)
        else:
            v = read_c3d(path)
        bad = plausible(v)
        out = ["nonsense", bad] if bad else ["ok", int(v.n_frames)]
    except MotionFormatError as e:
        out = ["error", str(e)] if e.path == path else ["nopath", str(e)]
    except BaseException as e:
        out = ["other", f"{type(e).__name__}: {e}"[:500]]
    sys.stdout.write(json.dumps(out) + "\n")
    sys.stdout.flush()
'''


class Reader:
    """A child process that reads files on request; a crash or hang fails the example."""

    #: s; longer than the C3D reader's own guard (``mocomp.io.c3d._CHILD_TIMEOUT``, 20 s + 2 s/MB, after
    #: which a looping ezc3d is reported as MotionFormatError), so that a hang means the reader's guard
    #: failed, not that a loaded machine was slow (a 20 s limit here once fired under load, CI clone run)
    TIMEOUT = 60.0

    def __init__(self, code: str = _WORKER):
        self.code = code
        self.p = None

    def _start(self):
        self.p = subprocess.Popen([sys.executable, "-c", self.code], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                  stderr=subprocess.DEVNULL, text=True, bufsize=1)

    def read(self, fmt: str, path: Path, extra=None):
        if self.p is None or self.p.poll() is not None:
            self._start()
        self.p.stdin.write(json.dumps([fmt, str(path), None if extra is None else str(extra)]) + "\n")
        self.p.stdin.flush()
        ready, _, _ = select.select([self.p.stdout], [], [], self.TIMEOUT)
        if not ready:
            self.p.kill()
            self.p.wait()
            self.p = None
            return ("hang", f"no answer within {self.TIMEOUT} s")
        line = self.p.stdout.readline()
        if not line:
            code = self.p.wait()
            self.p = None
            return ("crash", f"reader process died with status {code}")
        return tuple(json.loads(line))

    def close(self):
        if self.p is not None and self.p.poll() is None:
            self.p.stdin.close()
            self.p.wait(timeout=10)


@pytest.fixture(scope="module")
def reader():
    r = Reader()
    yield r
    r.close()


def check(result, path):
    kind, detail = result
    event(kind)
    assert kind in ("ok", "error"), f"{kind}: {detail}"
    if kind == "error":
        assert str(path) in detail


# ------------------------------------------------------------------ mutations
NUMBERS = ["nan", "NaN", "inf", "-inf", "Infinity", "1e308", "-1e308", "1e-300", "1e-320", "1e400", "9" * 400,
           "1" + "0" * 5001, "0", "-0", "1e6", "-1e4", "1e10", "²", "٣", "1.2.3", "-", "0x10", ""]
UNICODE = ["²", "٣", "é", "\u00a0", "\ufeff", "\u2028", "𝟘", "\x00", "\x85"]


@st.composite
def mutated_text(draw, seeds: list[str], nest: str = "{\n"):
    text = draw(st.sampled_from(seeds))
    for _ in range(draw(st.integers(1, 3))):
        op = draw(st.sampled_from(["flip", "delete", "duplicate", "swap", "number", "number", "count", "unicode",
                                   "line_ends", "truncate", "nest"]))
        if op == "flip" and text:
            b = bytearray(text.encode("utf-8", "surrogateescape"))
            for _ in range(draw(st.integers(1, 4))):
                b[draw(st.integers(0, len(b) - 1))] = draw(st.integers(0, 255))
            text = b.decode("latin-1")
        elif op in ("delete", "duplicate", "swap"):
            lines = text.split("\n")
            i = draw(st.integers(0, len(lines) - 1))
            if op == "delete":
                del lines[i]
            elif op == "duplicate":
                lines.insert(i, lines[i])
            else:
                j = draw(st.integers(0, len(lines) - 1))
                lines[i], lines[j] = lines[j], lines[i]
            text = "\n".join(lines)
        elif op == "number":
            spans = [m.span() for m in re.finditer(r"-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?", text)]
            if spans:
                a, b = spans[draw(st.integers(0, len(spans) - 1))]
                text = text[:a] + draw(st.sampled_from(NUMBERS)) + text[b:]
        elif op == "count":
            spans = [m.span(1) for m in re.finditer(r"(?:Frames:\s*|CHANNELS\s+|^)(\d+)\s*$", text, re.M)]
            if spans:
                a, b = spans[draw(st.integers(0, len(spans) - 1))]
                text = text[:a] + draw(st.sampled_from(["0", "1", "2", "7", "999999999", "1000000000", "-5"])) + \
                    text[b:]
        elif op == "unicode":
            i = draw(st.integers(0, len(text)))
            text = text[:i] + draw(st.sampled_from(UNICODE)) + text[i:]
        elif op == "line_ends":
            text = text.replace("\n", draw(st.sampled_from(["\r\n", "\r", "\n\n"])))
        elif op == "truncate":
            text = text[:draw(st.integers(0, len(text)))]
        else:
            i = draw(st.integers(0, len(text)))
            text = text[:i] + nest * draw(st.sampled_from([10, 3000, 100_000])) + text[i:]
    return text


def _write(tmp: Path, name: str, text: str) -> Path:
    p = tmp / name
    p.write_bytes(text.encode("utf-8", "surrogateescape"))
    return p


def _real(rel: str) -> Path | None:
    d = data_dir()
    p = None if d is None else d / rel
    if p is None or not p.is_file():
        if IN_CI:
            raise RuntimeError(f"CI=true but the real seed {rel} is missing")
        return None
    return p


def _cut_frames(text: str, n: int) -> str:
    lines = text.split("\n")
    k = next(i for i, ln in enumerate(lines) if ln.startswith("Frames:"))
    return "\n".join(lines[:k] + [f"Frames: {n}"] + lines[k + 1:k + 2 + n]) + "\n"


# ------------------------------------------------------------------ seeds
def _bvh_seeds() -> list[str]:
    from test_io_bvh import GOOD, bandai_style_text

    seeds = [GOOD, bandai_style_text(T=3)]
    for rel in ("jumps/01_01.bvh", "reactions/ase_rl_Dodgle_Left.derived.bvh"):
        p = _real(rel)
        if p is not None:
            seeds.append(_cut_frames(p.read_bytes().decode("latin-1"), 6))
    return seeds


def _amc_seeds() -> tuple[list[str], list[str]]:
    from test_io_asf_amc import ASF, amc_text

    asfs, amcs = [ASF], [amc_text(T=4)]
    a, m = _real("jumps/01.asf"), _real("jumps/01_01.amc")
    if a is not None:
        lines = m.read_bytes().decode("latin-1").split("\n")
        frames = [i for i, ln in enumerate(lines) if ln.strip().isdigit()]
        asfs.append(a.read_bytes().decode("latin-1"))
        amcs.append("\n".join(lines[:frames[4]]) + "\n")
    return asfs, amcs


SEEDS: dict = {"bvh": _bvh_seeds()}
SEEDS["asf"], SEEDS["amc"] = _amc_seeds()


def seeds(kind):
    return SEEDS[kind]


# ------------------------------------------------------------------ the properties
@FUZZ
@given(data=st.data())
def test_fuzz_bvh(reader, tmp_path, data):
    text = data.draw(mutated_text(seeds("bvh")))
    path = _write(tmp_path, "fuzz.bvh", text)
    check(reader.read("bvh", path), path)


@FUZZ
@given(data=st.data())
def test_fuzz_asf_amc(reader, tmp_path, data):
    """The AMC mutated against its ASF (3 of 4 examples) or the ASF against its AMC."""
    asfs, amcs = seeds("asf"), seeds("amc")
    k = data.draw(st.integers(0, len(asfs) - 1))
    asf, amc = _write(tmp_path, "s.asf", asfs[k]), _write(tmp_path, "m.amc", amcs[k])
    if data.draw(st.integers(0, 3)):
        path = _write(tmp_path, "fuzz.amc", data.draw(mutated_text([amcs[k]])))
        check(reader.read("amc", path, asf), path)
    else:
        path = _write(tmp_path, "fuzz.asf", data.draw(mutated_text([asfs[k]])))
        result = reader.read("asf", path, amc)
        if result[0] == "error" and str(amc) in result[1]:
            result = ("error", str(path) + result[1])  # an AMC error caused by the mutated ASF's dofs
        check(result, path)


def _deepmimic_seeds(tmp: Path):
    from test_io_deepmimic import motion_doc, small_character, write_motion

    char = small_character(tmp)
    out = [(char.read_text(), write_motion(tmp, motion_doc(T=4)).read_text(),
            write_motion(tmp, motion_doc(T=4, dts=[0.05, 0.1, 0.05, 0.0]), "nu.txt").read_text())]
    c, m = _real("skeletons/deepmimic_humanoid3d_character.txt"), _real("flips/deepmimic_backflip.txt")
    if c is not None:
        out.append((c.read_text(), m.read_text(), m.read_text()))
    return out


def _in_tmp(fn):
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        return fn(Path(d))


DEEPMIMIC_SEEDS = _in_tmp(_deepmimic_seeds)


@FUZZ
@given(data=st.data())
def test_fuzz_deepmimic(reader, tmp_path, data):
    """Motion files mutated against their character (3 of 4), or the character file."""
    sets = DEEPMIMIC_SEEDS
    char, motion, nonuniform = sets[data.draw(st.integers(0, len(sets) - 1))]
    cpath = _write(tmp_path, "char.txt", char)
    if data.draw(st.integers(0, 3)):
        path = _write(tmp_path, "fuzz.txt", data.draw(mutated_text([motion, nonuniform], nest="[")))
        check(reader.read("deepmimic", path, cpath), path)
    else:
        mpath = _write(tmp_path, "m.txt", motion)
        path = _write(tmp_path, "fuzzchar.txt", data.draw(mutated_text([char], nest="[")))
        result = reader.read("character", path, mpath)
        if result[0] == "error" and str(mpath) in result[1]:
            result = ("error", str(path) + result[1])  # the motion no longer fits the mutated character
        check(result, path)


def _c3d_seeds(tmp: Path) -> list[bytes]:
    import ezc3d

    c = ezc3d.c3d()
    c["parameters"]["POINT"]["RATE"]["value"] = [100.0]
    c["parameters"]["POINT"]["LABELS"]["value"] = ["A", "B", "C"]
    c["parameters"]["POINT"]["UNITS"]["value"] = ["mm"]
    data = np.ones((4, 3, 5))
    data[:3] = np.random.default_rng(0).uniform(-1000, 1000, (3, 3, 5))
    c["data"]["points"] = data
    c["data"]["meta_points"] = {"residuals": np.zeros((1, 3, 5))}
    c.write(str(tmp / "seed.c3d"))
    out = [(tmp / "seed.c3d").read_bytes()]
    p = _real("hands/HDM_dg_06-03_03_120.c3d")
    if p is not None:
        out.append(p.read_bytes())
    return out


C3D_SEEDS = _in_tmp(_c3d_seeds)


@st.composite
def mutated_bytes(draw, seed: bytes):
    import struct

    b = bytearray(seed)
    for _ in range(draw(st.integers(1, 3))):
        op = draw(st.sampled_from(["flip", "truncate", "header", "parameters", "parameters"]))
        if op == "flip" and b:
            for _ in range(draw(st.integers(1, 8))):
                b[draw(st.integers(0, len(b) - 1))] = draw(st.integers(0, 255))
        elif op == "truncate":
            b = b[:draw(st.integers(0, len(b)))]
        elif op == "header" and len(b) >= 24:
            w = draw(st.integers(0, 11))
            b[2 * w:2 * w + 2] = struct.pack("<h", draw(st.sampled_from([0, 1, -1, 2, 32767, -32768, 65535 - 65536])))
        elif len(b) > 600:  # the parameter section (blocks 2..)
            end = min(len(b), 512 * 12)
            for _ in range(draw(st.integers(1, 6))):
                b[draw(st.integers(512, end - 1))] = draw(st.integers(0, 255))
    return bytes(b)


@FUZZ
@given(data=st.data())
def test_fuzz_c3d(reader, tmp_path, data):
    """ezc3d used to segfault (38 in 3,000), hang (4) or silently drop frames on such files."""
    s = C3D_SEEDS
    raw = data.draw(mutated_bytes(s[data.draw(st.integers(0, len(s) - 1))]))
    path = tmp_path / "fuzz.c3d"
    path.write_bytes(raw)
    check(reader.read("c3d", path), path)


@pytest.mark.parametrize("code, kind", [
    ("import os, signal, sys; sys.stdin.readline(); os.kill(os.getpid(), signal.SIGSEGV)", "crash"),
    ("import sys, time; sys.stdin.readline(); time.sleep(60)", "hang"),
])
def test_reader_process_reports_crashes_and_hangs(tmp_path, monkeypatch, code, kind):
    """The harness itself: a reader that dies or stalls is reported (and restarted), not waited on."""
    monkeypatch.setattr(Reader, "TIMEOUT", 1.0)
    r = Reader(code)
    assert r.read("bvh", tmp_path / "x.bvh")[0] == kind
    assert r.p is None  # the next example gets a fresh process
