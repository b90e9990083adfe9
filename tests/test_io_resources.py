"""Resource bounds of the readers (issue 12): files that claim absurd sizes -- 10^9
frames, 10,000 joints, 200 MB of junk -- get a clear MotionFormatError within seconds
and under 500 MB peak memory, instead of allocating gigabytes or parsing for minutes.

Each read runs in a fresh child process that reports its own peak resident memory
(``resource.getrusage``, which includes the interpreter and numpy/scipy, ~100 MB) and
wall time. The bounds here are generous guards (10 s, 500 MB); the measured values
are in the issue note, and speed goals live in benchmarks/.
"""
from __future__ import annotations

import json
import struct
import subprocess
import sys

import pytest

from conftest import IN_CI

MAX_SECONDS = 10.0
MAX_RSS_MB = 500.0

_CHILD = r'''
import json, resource, sys, time, warnings
warnings.simplefilter("ignore")


def peak_mb():
    # VmHWM: this process image's own peak RSS. ru_maxrss is not: on Linux it survives execve, so a
    # child of a large pytest process (fork copies its resident set) starts at the parent's peak.
    try:
        with open("/proc/self/status") as f:
            return next(int(l.split()[1]) for l in f if l.startswith("VmHWM:")) / 1024
    except (OSError, StopIteration):
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


from mocomp.errors import MotionFormatError
from mocomp.io import read_amc, read_asf, read_bvh, read_c3d, read_deepmimic
import mocomp.io.bvh, mocomp.io.deepmimic  # imports before the clock starts
fmt, path, extra = sys.argv[1], sys.argv[2], (sys.argv[3] if len(sys.argv) > 3 else None)
base = peak_mb()
t = time.perf_counter()
try:
    {"bvh": lambda: read_bvh(path), "amc": lambda: read_amc(path, asf=extra), "asf": lambda: read_asf(path),
     "deepmimic": lambda: read_deepmimic(path, character=extra), "c3d": lambda: read_c3d(path)}[fmt]()
    out = ["ok", ""]
except MotionFormatError as e:
    out = ["error", str(e)]
except BaseException as e:
    out = ["other", f"{type(e).__name__}: {e}"[:300]]
dt = time.perf_counter() - t
print(json.dumps(out + [dt, peak_mb(), base]))
'''


def read_measured(fmt, path, extra=None):
    """(kind, message, seconds, peak RSS MB, RSS MB after imports) of one read in a fresh process."""
    args = [sys.executable, "-c", _CHILD, fmt, str(path)] + ([str(extra)] if extra else [])
    r = subprocess.run(args, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr[-2000:]
    return tuple(json.loads(r.stdout.strip().splitlines()[-1]))


def assert_refused_quickly(result, path, *words):
    kind, msg, seconds, rss, base = result
    assert kind == "error", (kind, msg)
    assert str(path) in msg and all(w in msg for w in words), msg
    assert seconds < MAX_SECONDS, f"{seconds:.1f} s"
    assert rss < MAX_RSS_MB, f"peak RSS {rss:.0f} MB (after imports {base:.0f} MB)"
    print(f"{path.name}: {seconds * 1e3:.0f} ms, peak RSS {rss:.0f} MB (imports {base:.0f} MB): {msg[:120]}")


HEADER = """HIERARCHY
ROOT Hips
{
\tOFFSET 0 0 0
\tCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
\tEnd Site
\t{
\t\tOFFSET 0 10 0
\t}
}
MOTION
"""


def test_bvh_claiming_a_billion_frames(tmp_path):
    f = tmp_path / "billion.bvh"
    f.write_text(HEADER + "Frames: 1000000000\nFrame Time: 0.0083333\n" + "0 90 0 1 2 3\n" * 10)
    assert_refused_quickly(read_measured("bvh", f), f, "Frames: 1000000000 (more than the 1,000,000 accepted)")
    # the same claim with a frame block that is large but far too short for it
    g = tmp_path / "billion_big.bvh"
    g.write_text(HEADER + "Frames: 999999\nFrame Time: 0.0083333\n" + "0 90 0 1 2 3\n" * 200_000)
    assert_refused_quickly(read_measured("bvh", g), g, "Frames: 999999 but only 200000 frame lines")


def test_bvh_with_ten_thousand_joints(tmp_path):
    lines = ["HIERARCHY", "ROOT Hips", "{", "\tOFFSET 0 0 0",
             "\tCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation"]
    for k in range(10_000):
        lines += [f"\tJOINT j{k}", "\t{", "\t\tOFFSET 0 1 0", "\t\tCHANNELS 3 Zrotation Xrotation Yrotation",
                  "\t\tEnd Site", "\t\t{", "\t\t\tOFFSET 0 1 0", "\t\t}", "\t}"]
    lines += ["}", "MOTION", "Frames: 2", "Frame Time: 0.01"] + [" ".join(["0"] * 30006)] * 2
    f = tmp_path / "wide.bvh"
    f.write_text("\n".join(lines) + "\n")
    assert_refused_quickly(read_measured("bvh", f), f, "more than 1000 joints")


@pytest.fixture(scope="module")
def junk_200mb(tmp_path_factory):
    """200 MB of digits and spaces (no line ends), written once for the module."""
    d = tmp_path_factory.mktemp("junk")
    f = d / "junk.bin"
    block = (b"8675309 3.14159 " * 4096)[:65536]
    with open(f, "wb") as fh:
        for _ in range(200 * 1024 * 1024 // len(block)):
            fh.write(block)
    assert f.stat().st_size == 200 * 1024 * 1024
    return f


@pytest.mark.parametrize("fmt, ext, words", [
    ("bvh", ".bvh", "does not start with HIERARCHY"),
    ("c3d", ".c3d", "not the C3D key 0x50"),
    ("asf", ".asf", "line 1 is longer than 65536 bytes"),
    ("deepmimic", ".txt", "not valid JSON (motion file): it starts with '8675309"),
])
def test_two_hundred_megabytes_of_junk(junk_200mb, tmp_path, fmt, ext, words):
    f = tmp_path / f"junk{ext}"
    f.symlink_to(junk_200mb)
    extra = None
    if fmt == "deepmimic":
        from test_io_deepmimic import small_character

        extra = small_character(tmp_path)
    assert_refused_quickly(read_measured(fmt, f, extra), f, words)


def test_amc_of_two_hundred_megabytes_of_junk(junk_200mb, tmp_path):
    from test_io_asf_amc import ASF

    (tmp_path / "s.asf").write_text(ASF)
    f = tmp_path / "junk.amc"
    f.symlink_to(junk_200mb)
    assert_refused_quickly(read_measured("amc", f, tmp_path / "s.asf"), f, "line 1 is longer than")


def test_c3d_claiming_the_most_frames_its_header_can(tmp_path):
    """The header's 16-bit last frame at 65535 (and POINT:FRAMES with it) on a 6-frame file."""
    from test_io_c3d import sample_points, write_c3d

    f = write_c3d(tmp_path / "ok.c3d", sample_points(M=3, T=6), "ABC")
    raw = bytearray(f.read_bytes())
    raw[8:10] = struct.pack("<H", 65535)
    p0 = (raw[0] - 1) * 512
    q = raw.index(b"FRAMES", p0) + 6 + 2  # POINT:FRAMES: after its name and offset, type and dims
    assert raw[q] == 2 and raw[q + 1] == 0  # an int16 scalar
    raw[q + 2:q + 4] = struct.pack("<h", -1)  # 65535 as unsigned
    g = tmp_path / "many.c3d"
    g.write_bytes(bytes(raw))
    assert_refused_quickly(read_measured("c3d", g), g, "describes 65535 frames", "frames are missing")


def test_bvh_header_followed_by_two_hundred_megabytes_of_junk(junk_200mb, tmp_path):
    """A valid header, then 200 MB without a line end (50 MB took 2.9 s and 617 MB before)."""
    f = tmp_path / "hjunk.bvh"
    with open(f, "wb") as out, open(junk_200mb, "rb") as src:
        out.write((HEADER + "Frames: 5\nFrame Time: 0.01\n").encode())
        while chunk := src.read(1 << 24):
            out.write(chunk)
    assert_refused_quickly(read_measured("bvh", f), f, "more than Frames: 5 lines of 6 values can hold")
    # the same junk with a Frames: count that could hold it: the streamed error search
    g = tmp_path / "hjunk2.bvh"
    with open(g, "wb") as out, open(junk_200mb, "rb") as src:
        out.write((HEADER + "Frames: 999999\nFrame Time: 0.01\n").encode())
        while chunk := src.read(1 << 24):
            out.write(chunk)
    assert_refused_quickly(read_measured("bvh", g), g, "frame line is longer than 386 bytes")
