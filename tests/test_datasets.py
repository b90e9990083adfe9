"""mocomp.datasets: examples, real clips by name, known corrections, CMU download (local server only)."""
from __future__ import annotations

import hashlib
import http.server
import json
import re
import threading
import types
import warnings
from functools import partial
from pathlib import Path

import numpy as np
import pytest

from mocomp import datasets
from mocomp.core import Motion
from mocomp.datasets import clips, download
from mocomp.datasets.examples import EXAMPLES, Example
from mocomp.errors import ChecksumError, DataNotFoundError, MotionFormatError
from mocomp.io import UNITS, write_bvh

from _figures import small_motion
from conftest import real_files


# --------------------------------------------------------------- helpers


@pytest.fixture
def fake_example(monkeypatch):
    """A registered example whose generator counts its calls."""
    calls = []

    def make():
        calls.append(1)
        return types.SimpleNamespace(motion=small_motion(seed=3), truth={"mass": 70.0})

    monkeypatch.setitem(EXAMPLES, "unit_test_example", Example("unit_test_example", "a test figure", make))
    datasets._make_example.cache_clear()
    yield calls
    datasets._make_example.cache_clear()


@pytest.fixture
def fake_data_dir(tmp_path, monkeypatch):
    """A data directory with CMU-, SFU-, DeepMimic-named files and a character file."""
    root = tmp_path / "data"
    (root / "flips").mkdir(parents=True)
    (root / "jumps").mkdir()
    (root / "skeletons").mkdir()
    cmu = UNITS["cmu"]
    write_bvh(small_motion(tpose=True), root / "flips" / "cmu_88_07_testflip.bvh", scale=cmu)
    f = write_bvh(small_motion(seed=1), root / "jumps" / "01_01.bvh", scale=cmu)
    f.write_text(re.sub(r"Frame Time: \S+", "Frame Time: .0083333", f.read_text()))  # as cgspeed writes it
    (root / "jumps" / "01_01.amc").write_text(":FULLY-SPECIFIED\n:DEGREES\n1\nroot 0 0 0 0 0 0\n")
    write_bvh(small_motion(seed=2), root / "jumps" / "sfu_0005_Hop001.bvh", scale=0.0254)
    (root / "jumps" / "deepmimic_hop.txt").write_text('{"Loop": "none", "Frames": [[0.1, 0, 1, 0, 1, 0, 0, 0]]}')
    (root / "skeletons" / "deepmimic_character.txt").write_text('{"Skeleton": {"Joints": []}}')
    (root / "MANIFEST.md").write_text(
        "| file | trial | description | format |\n|---|---|---|---|\n"
        "| `flips/cmu_88_07_testflip.bvh` | CMU 88_07 | A test flip. More words here | BVH |\n")
    monkeypatch.setenv("MOCOMP_DATA_DIR", str(root))
    return root


# --------------------------------------------------------------- examples
def test_example_load_is_cached_and_carries_truth(fake_example):
    m = datasets.load("unit_test_example")
    assert isinstance(m, Motion) and m.n_frames == 12
    assert datasets.load("unit_test_example") is m
    full = datasets.load_example("unit_test_example")
    assert full.motion is m and full.truth == {"mass": 70.0}
    assert len(fake_example) == 1  # generated once per process


def test_example_rejects_file_options(fake_example):
    with pytest.raises(ValueError, match="generated example"):
        datasets.load("unit_test_example", fps=60)
    with pytest.raises(ValueError, match="generated example"):
        datasets.load("unit_test_example", scale="cm")


def test_unknown_example(fake_example):
    with pytest.raises(DataNotFoundError, match="no embedded example 'nope'; examples: .*unit_test_example"):
        datasets.load_example("nope")


def test_list_without_data_dir(fake_example, monkeypatch):
    monkeypatch.delenv("MOCOMP_DATA_DIR", raising=False)
    df = datasets.list()
    assert list(df.columns) == ["name", "kind", "description", "path", "format"]
    row = df[df.name == "unit_test_example"].iloc[0]
    assert row.kind == "example" and row.description == "a test figure"
    assert set(df.kind) == {"example"}
    dl = datasets.list(downloadable=True)
    assert "87_03" in set(dl[dl.kind == "downloadable"].name)


def test_synth_examples_are_listed_and_load():
    ex = datasets.examples()
    assert set(ex) >= {"backflip", "frontflip", "sideflip", "twist180", "twist360", "jump"}
    m = datasets.load("backflip")
    assert isinstance(m, Motion) and m.n_frames > 10
    assert hasattr(datasets.load_example("backflip"), "motion")


# --------------------------------------------------------------- finding clips
def test_real_clips_and_find_clip(fake_data_dir):
    rel = [p.relative_to(fake_data_dir).as_posix() for p in datasets.real_clips()]
    assert rel == ["flips/cmu_88_07_testflip.bvh", "jumps/01_01.amc", "jumps/01_01.bvh",
                   "jumps/deepmimic_hop.txt", "jumps/sfu_0005_Hop001.bvh"]  # no character file
    find = datasets.find_clip
    assert find("88_07").name == "cmu_88_07_testflip.bvh"
    assert find("088_7").name == "cmu_88_07_testflip.bvh"
    assert find("cmu_88_07_testflip") == find("flips/cmu_88_07_testflip.bvh") == find("CMU_88_07_TESTFLIP.bvh")
    assert find("01_01").suffix == ".bvh"  # BVH preferred over AMC
    assert find("01_01.amc").suffix == ".amc" and find("jumps/01_01.amc").suffix == ".amc"
    assert find("1_1").suffix == ".bvh"
    assert find("deepmimic_hop").suffix == ".txt"


def test_list_names_resolve_to_their_files(fake_data_dir):
    df = datasets.list()
    real = df[df.kind == "real"]
    assert len(real) == 5
    for r in real.itertuples():
        assert datasets.find_clip(r.name) == fake_data_dir / r.path
    row = real[real.path == "flips/cmu_88_07_testflip.bvh"].iloc[0]
    assert row.description == "A test flip"  # first sentence from MANIFEST.md
    assert real[real.path == "jumps/01_01.amc"].iloc[0]["name"] == "01_01.amc"
    dl = datasets.list(downloadable=True)
    assert "88_07" not in set(dl[dl.kind == "downloadable"].name)  # present locally


def test_not_found_messages(fake_data_dir, monkeypatch):
    with pytest.raises(DataNotFoundError) as e:
        datasets.load("cmu_88_07_testflp")
    msg = str(e.value)
    assert str(fake_data_dir) in msg and "close: cmu_88_07_testflip" in msg and "CMU trial id" in msg
    with pytest.raises(DataNotFoundError, match=r"CMU 87_03 can be downloaded: .*download=True"):
        datasets.load("87_03")
    with pytest.raises(DataNotFoundError, match="get CMU trial 99_99 from mocap.cs.cmu.edu"):
        datasets.load("99_99")
    (fake_data_dir / "flips" / "01_01.bvh").write_bytes((fake_data_dir / "jumps" / "01_01.bvh").read_bytes())
    with pytest.raises(DataNotFoundError, match="ambiguous.*flips/01_01.bvh, jumps/01_01.bvh"):
        datasets.load("01_01")
    monkeypatch.delenv("MOCOMP_DATA_DIR")
    with pytest.raises(DataNotFoundError, match="no real-data directory is set: set MOCOMP_DATA_DIR"):
        datasets.load("88_07")
    with pytest.raises(DataNotFoundError, match="'bandai2_dance_001' is named like a clip of the Bandai Namco "
                                                "Research Motion Dataset data: the 'source' column of the data "
                                                "set's MANIFEST.md"):
        datasets.load("bandai2_dance_001")
    monkeypatch.setenv("MOCOMP_DATA_DIR", str(fake_data_dir / "missing"))
    with pytest.raises(DataNotFoundError, match="is not a directory"):
        datasets.load("88_07")
    with pytest.raises(DataNotFoundError, match="no such file"):
        datasets.load(Path("/no/such/file.bvh"))
    for d in (fake_data_dir / "jumps", str(fake_data_dir / "jumps")):
        with pytest.raises(DataNotFoundError, match=f"{fake_data_dir / 'jumps'} is a directory, not a motion file"):
            datasets.load(d)


@pytest.mark.parametrize("name, data_set", [
    ("sfu_0005_Hop002", "SFU Motion Capture Database"),
    ("bandai1_kick_fast_001", "Bandai Namco Research Motion Dataset"),
    ("deepmimic_dance_a", "DeepMimic motion"),
    ("mass_run.bvh", "MASS (retargeted BVH)"),
    ("hdm05_cartwheel", "HDM05"),
    ("HDM_bd_01-01_01_120.amc", "HDM05"),
])
def test_not_found_hint_per_source(name, data_set, fake_data_dir):
    """Non-CMU names get a how-to-obtain hint for their data set, pointing at the MANIFEST's
    source column; a clip listed there but missing from the folder gets its row's source quoted."""
    with pytest.raises(DataNotFoundError) as e:
        datasets.load(name)
    msg = str(e.value)
    assert f"{Path(name).name!r} is named like a clip of the {data_set}" in msg, msg
    assert f"the 'source' column of {fake_data_dir / 'MANIFEST.md'}" in msg and f"put it in {fake_data_dir}" in msg
    assert "MANIFEST row for it" not in msg  # not listed in this MANIFEST


def test_not_found_hint_quotes_the_manifest_row(fake_data_dir):
    (fake_data_dir / "MANIFEST.md").write_text(
        "| file | description | source (repo @ commit : path) | notes |\n|---|---|---|---|\n"
        "| `jumps/sfu_0005_Hop002.bvh` | hops | `owner/repo` @ `abc123` : `tests/0005_Hop002.bvh` | inches |\n")
    with pytest.raises(DataNotFoundError) as e:
        datasets.load("sfu_0005_Hop002")
    assert "(MANIFEST row for it: owner/repo @ abc123 : tests/0005_Hop002.bvh)" in str(e.value)
    with pytest.raises(DataNotFoundError) as e:  # a name of no known source: no data-set hint
        datasets.load("walk_unknown")
    assert "named like a clip" not in str(e.value)


# --------------------------------------------------------------- corrections
def test_facts_table():
    f = clips.facts_for("flips/cmu_88_01_backflip.bvh")
    assert (f.source, f.unit, f.fps, f.tpose_first_frame) == ("cmu", "cmu", 60.0, True)
    assert "gravity" in f.fps_reason
    assert clips.facts_for("cmu_90_08_sideflip.bvh").fps == 60.0
    assert clips.facts_for("twists/cmu_83_58_hopturn270.bvh").fps is None  # really 120 Hz
    assert clips.facts_for("01_01.bvh").fps is None and clips.facts_for("01_01.bvh").unit == "cmu"
    assert clips.facts_for("01_01.amc").unit is None  # the ASF units block says
    assert clips.facts_for("sfu_0005_Jogging001.bvh").unit == "inch"
    assert clips.facts_for("bandai2_walk_normal_001.bvh").unit == "cm"
    assert clips.facts_for("mass_backflip.bvh").unit == "cm" and clips.facts_for("mass_backflip.bvh").notes
    assert clips.facts_for("deepmimic_backflip.txt").unit == "m"
    assert clips.facts_for("HDM_dg_06-03_03_120.c3d").unit == "mm"
    assert clips.facts_for("my_take.bvh") == clips.ClipFacts()
    assert clips.cmu_trial("cmu_141_16_wave") == (141, 16) and clips.cmu_trial("sfu_0005") is None


def test_load_applies_corrections_with_notes(fake_data_dir):
    m = datasets.load("88_07")
    raw = datasets.load("88_07", raw=True)
    assert raw.n_frames == 12 and m.n_frames == 11  # T-pose frame dropped
    assert m.fps == 60.0 and raw.fps == pytest.approx(120.0, rel=1e-4)
    assert m.source.header_fps == pytest.approx(120.0, rel=1e-4)
    np.testing.assert_allclose(m.positions, raw.positions[1:], atol=1e-12)
    assert m.source.unit_scale == UNITS["cmu"] and "1/0.45 inch" in m.source.unit_reason
    notes = " ".join(m.source.notes)
    assert "60 Hz used instead of the header" in notes and "T-pose" in notes
    assert not any("T-pose" in n for n in raw.source.notes)
    # the original figure comes back in metres
    np.testing.assert_allclose(m.positions, small_motion(tpose=True).positions[1:], atol=1e-6)
    # explicit overrides win
    m50 = datasets.load("88_07", fps=50)
    assert m50.fps == 50 and not any("used instead" in n for n in m50.source.notes)
    with pytest.warns(UserWarning, match="standing height"):
        mcm = datasets.load("88_07", scale="cm")
    assert mcm.source.unit_scale == 0.01
    # a non-T-pose first frame is kept; a rounded 120 Hz header snaps to 120
    h = datasets.load("01_01")
    assert h.n_frames == 12 and h.fps == 120.0 and "rounded frame time" in " ".join(h.source.notes)
    s = datasets.load("sfu_0005_Hop001")
    assert s.source.unit_scale == 0.0254
    np.testing.assert_allclose(s.positions, small_motion(seed=2).positions, atol=1e-6)
    # the same corrections apply when loading by path
    p = datasets.load(fake_data_dir / "flips" / "cmu_88_07_testflip.bvh")
    assert p.fps == 60 and p.n_frames == 11


def test_unreadable_clip_raises_format_error(fake_data_dir):
    with pytest.raises(MotionFormatError, match="01_01.amc"):  # a stub AMC without its ASF
        datasets.load("01_01.amc")


def test_tpose_detection():
    assert clips.is_tpose_frame(small_motion(tpose=True))
    assert not clips.is_tpose_frame(small_motion(tpose=False))
    assert not clips.is_tpose_frame(small_motion(tpose=True)[:1])


# --------------------------------------------------------------- download (local server only)
class _Handler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):
        pass

    def do_GET(self):
        self.server.hits.append(self.path)
        return super().do_GET()


@pytest.fixture
def local_server(tmp_path):
    """An HTTP server on 127.0.0.1 serving tmp_path/www; yields (www, url_template, hits)."""
    www = tmp_path / "www"
    www.mkdir()
    srv = http.server.ThreadingHTTPServer(("127.0.0.1", 0), partial(_Handler, directory=str(www)))
    srv.hits = []
    th = threading.Thread(target=srv.serve_forever, daemon=True)
    th.start()
    try:
        yield www, f"http://127.0.0.1:{srv.server_address[1]}/{{repo}}/{{commit}}/{{path}}", srv.hits
    finally:
        srv.shutdown()
        srv.server_close()


def _serve(www: Path, trial: str, data: bytes) -> Path:
    loc = download.CMU_REGISTRY[trial]
    f = www / loc.repo / loc.commit / loc.path
    f.parent.mkdir(parents=True, exist_ok=True)
    f.write_bytes(data)
    return f


def test_fetch_cmu_records_and_checks_sha256(local_server, tmp_path):
    www, url, hits = local_server
    cache = tmp_path / "cache"
    buf = tmp_path / "gen.bvh"
    write_bvh(small_motion(tpose=True, seed=5), buf, scale=UNITS["cmu"])
    data = buf.read_bytes()
    served = _serve(www, "87_03", data)
    p = download.fetch_cmu("87_03", cache=cache, url_template=url)
    assert p == cache / "cmu_87_03.bvh" and p.read_bytes() == data and len(hits) == 1
    rec = json.loads((cache / "registry.json").read_text())
    assert rec == {"87_03": "sha256:" + hashlib.sha256(data).hexdigest()}
    # second fetch: verified from the cache, no request
    assert download.fetch_cmu("87_3", cache=cache, url_template=url) == p and len(hits) == 1
    # a corrupted cache file is fetched again and checked
    p.write_bytes(b"garbage")
    download.fetch_cmu("87_03", cache=cache, url_template=url)
    assert p.read_bytes() == data and len(hits) == 2
    # the server's bytes change: checksum error
    p.unlink()
    served.write_bytes(data + b"\n")
    with pytest.raises(ChecksumError, match="87_03"):
        download.fetch_cmu("87_03", cache=cache, url_template=url)
    # a wrong known hash is refused too
    with pytest.raises(ChecksumError):
        download.fetch_cmu("87_04", cache=cache, url_template=url, known_hash="sha256:" + "0" * 64) if _serve(
            www, "87_04", data) else None


def test_fetch_cmu_size_404_unknown(local_server, tmp_path):
    www, url, hits = local_server
    cache = tmp_path / "cache"
    _serve(www, "88_01", b"too short")  # the registry knows 88_01 has 158,001 bytes
    with pytest.raises(ChecksumError, match="9 bytes, the registry says 158001"):
        download.fetch_cmu("88_01", cache=cache, url_template=url)
    assert not (cache / "cmu_88_01.bvh").exists()
    with pytest.raises(DataNotFoundError, match="could not download CMU 90_13"):
        download.fetch_cmu("90_13", cache=cache, url_template=url)  # 404
    with pytest.raises(DataNotFoundError, match="not in the download registry"):
        download.fetch_cmu("12_34", cache=cache, url_template=url)
    with pytest.raises(ValueError, match="not a CMU trial id"):
        download.fetch_cmu("backflip", cache=cache, url_template=url)


def test_load_with_download(local_server, tmp_path, monkeypatch, fake_data_dir):
    www, url, hits = local_server
    buf = tmp_path / "gen.bvh"
    write_bvh(small_motion(tpose=True, seed=6), buf, scale=UNITS["cmu"])
    _serve(www, "90_02", buf.read_bytes())
    monkeypatch.setenv(download.URL_ENV, url)
    monkeypatch.setenv(download.CACHE_ENV, str(tmp_path / "c2"))
    with pytest.raises(DataNotFoundError, match="download=True"):
        datasets.load("90_02")
    assert hits == []  # nothing fetched without download=True
    m = datasets.load("90_02", download=True)
    assert m.fps == 60.0 and m.n_frames == 11  # subject 90 runs at 60 Hz; T-pose dropped
    np.testing.assert_allclose(m.positions, small_motion(tpose=True, seed=6).positions[1:], atol=1e-6)
    assert download.cache_dir() == tmp_path / "c2"


# --------------------------------------------------------------- real clips (MOCOMP_DATA_DIR)
def test_real_flips_run_at_60_hz(real_data_dir):
    for name, frames in (("88_01", 202), ("88_05", 149), ("90_08", 337)):
        m = datasets.load(name)
        assert m.fps == 60.0 and m.n_frames == frames, name
        assert m.source.header_fps == pytest.approx(120.0, rel=1e-4)
        assert m.source.unit_scale == pytest.approx(0.0254 / 0.45)
        raw = datasets.load(name, raw=True)
        assert raw.n_frames == frames + 1 and raw.fps == pytest.approx(120.0, rel=1e-4)
    m = datasets.load("83_58")  # subject 83 really is 120 Hz
    assert m.fps == 120.0 and m.n_frames == 364


def test_real_units_give_human_heights(real_data_dir):
    from mocomp.io.units import standing_height

    for name, unit in (("01_01", "cmu"), ("sfu_0005_JumpRope001", "inch"), ("bandai2_walk_normal_001", "cm"),
                       ("131_01", "cmu")):
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # no height warning for these
            m = datasets.load(name)
        assert m.source.unit_scale == UNITS[unit]
        assert 1.3 < standing_height(m) < 2.0, name


def test_real_tpose_dropped_only_where_present(real_data_dir):
    a, r = datasets.load("01_01"), datasets.load("01_01", raw=True)
    assert a.n_frames == r.n_frames - 1 == 2751  # the AMC of the same take has 2751 frames
    np.testing.assert_array_equal(a.rotations, r.rotations[1:])
    assert datasets.load("131_03").n_frames == datasets.load("131_03", raw=True).n_frames == 1102


def test_real_list_names_resolve(real_data_dir):
    df = datasets.list()
    real = df[df.kind == "real"]
    assert len(real) >= 40
    for r in real.itertuples():
        assert datasets.find_clip(r.name) == real_data_dir / r.path
    assert (real.description != "").mean() > 0.9


REAL_MOTIONS = [p for p in real_files("**/*.bvh") + real_files("**/*.amc") + real_files("**/deepmimic_*.txt")
                if "character" not in p.name and p.parent.name not in ("skeletons", "metadata")]

#: frame rates the data MANIFEST states for ASE clips (3 decimals; "Added 2026-12-01" table)
ASE_MANIFEST_FPS = {"ase_rl_Dodge_Backward": 29.857, "ase_rl_Atk_Kick": 29.901, "ase_rl_Atk_SlashDown": 29.897,
                    "ase_rl_Fall_Left": 29.962, "ase_rl_Atk_4xCombo01": 29.97, "ase_rl_Dodgle_Left": 30.0,
                    "ase_rl_Fall_SpinRight": 29.999, "ase_rl_Fall_Backward": 29.998, "ase_rl_Atk_2xCombo01": 29.925}


@pytest.fixture(scope="module")
def real_names(real_data_dir):
    df = datasets.list()
    return {r.path: r.name for r in df[df.kind == "real"].itertuples()}


@pytest.mark.parametrize("path", REAL_MOTIONS, ids=lambda p: p.name)
def test_every_real_clip_loads_by_its_listed_name(path, real_names, real_data_dir):
    from mocomp.body.height import standing_height

    name = real_names[path.relative_to(real_data_dir).as_posix()]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = datasets.load(name)
    assert m.source.path == str(path)
    assert np.all(np.isfinite(m.positions))
    # the performer's height (measured when upright, from the bone lengths when never upright)
    assert 1.3 < standing_height(m) < 2.0, "implausible body height: wrong unit?"
    if path.name.startswith("ase_rl_"):
        # ASE clips keep their source's own non-integer rate (Frame Time = 1/fps), never rounded
        # (a whole 30 Hz the source wrote as Frame Time 0.0333333 is 30 Hz, as for every BVH)
        whole = datasets.rounded_frame_rate(m.source.header_fps)
        assert m.fps == (float(whole) if whole else m.source.header_fps) and 29.8 < m.fps <= 30.0
        stem = path.name.split(".")[0]
        if stem in ASE_MANIFEST_FPS:
            assert m.fps == pytest.approx(ASE_MANIFEST_FPS[stem], abs=6e-4)
    else:
        assert m.fps in (16.0, 30.0, 60.0, 120.0) or m.source.format == "deepmimic"


def test_registry_lists_exactly_the_motion_files(real_data_dir):
    """Walking the data folder (new folders reactions/, attacks/, combos/, runs/, idle/ ...) finds
    every motion file and nothing else (no licence text, MJCF model or CSV from skeletons/, metadata/)."""
    found = datasets.real_clips(real_data_dir)
    assert set(found) == set(REAL_MOTIONS)
    folders = {p.parent.name for p in found}
    assert {"reactions", "attacks", "combos", "runs", "idle", "kicks_punches", "walks"} <= folders
    assert not folders & {"skeletons", "metadata"}
    names = datasets.list().query("kind == 'real'").name
    assert names.is_unique and len(names) == len(found)


def test_ase_clips_load_by_source_stem(real_data_dir):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # metres by the clip facts: no unit warning
        m = datasets.load("ase_rl_Fall_Left")
    assert m.source.path == str(real_data_dir / "reactions" / "ase_rl_Fall_Left.derived.bvh")
    assert m.source.unit_scale == 1.0 and "ASE" in m.source.unit_reason
    assert m.fps == pytest.approx(29.962, abs=6e-4)
    assert any("kept as written" in n for n in m.source.notes)
    f = clips.facts_for("attacks/ase_rl_Atk_ShieldCharge.derived.bvh")
    assert (f.source, f.unit, f.fps) == ("ase", "m", None)


@pytest.mark.parametrize("frame_time, whole", [
    (".0083333", 120), ("0.008333", 120), ("0.00833333", 120), (".0166667", 60), ("0.0333333", 30),
    ("0.033333", 30), ("0.0333333333", 30), ("0.0625", 16),
    # ASE's own rates, printed to the digits that distinguish them from 30 Hz
    ("0.0334925", None), ("0.0333346008", None), ("0.0333349", None), ("0.0333351", None), ("0.0334111922", None),
])
def test_rounded_frame_rate(frame_time, whole):
    assert datasets.rounded_frame_rate(1.0 / float(frame_time)) == whole


def test_non_integer_bvh_rate_is_kept(tmp_path):
    """A BVH whose Frame Time states 29.857 Hz (ASE's Dodge_Backward) keeps that rate exactly;
    the previous relative 1e-4 snap turned 29.998 Hz into 30."""
    from mocomp.io import write_bvh

    for ft, want in (("0.0333355", 1 / 0.0333355), ("0.0334925", 1 / 0.0334925), ("0.0333333", 30.0)):
        f = tmp_path / f"ase_rl_Test_{ft[-4:]}.derived.bvh"
        write_bvh(small_motion(), f)
        f.write_text(re.sub(r"Frame Time: \S+", f"Frame Time: {ft}", f.read_text()))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            assert datasets.load(str(f)).fps == want, ft


@pytest.mark.parametrize("name", ["backflip", "frontflip", "sideflip", "twist180", "twist360", "jump"])
def test_every_embedded_example_lists_and_loads(name, monkeypatch):
    """Issue 2 section 4 / issue 3 section 3: each named example is listed with a one-line
    description and loads (without a data directory) as the generator's motion and truth."""
    monkeypatch.delenv("MOCOMP_DATA_DIR", raising=False)
    df = datasets.list()
    row = df[df.name == name]
    assert len(row) == 1 and row.iloc[0].kind == "example"
    desc = row.iloc[0].description
    assert desc and "\n" not in desc and len(desc) < 200
    m = datasets.load(name)
    truth = datasets.load_example(name)
    assert isinstance(m, Motion) and m.skeleton.n_joints == 31 and m.fps == 120.0
    np.testing.assert_array_equal(m.rotations, truth.motion.rotations)
    a, b = truth.flight
    assert 0 < a < b < m.n_frames and truth.body.total_mass == pytest.approx(70.0)
