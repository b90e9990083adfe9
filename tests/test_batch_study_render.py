"""``mocomp study render`` on mocomp.batch's mechanism (issue 20 section 2): stimuli rendered on a
2-worker Dask cluster give the same files (byte for byte) and manifest as in one process."""
from __future__ import annotations

import sys
from pathlib import Path

import imageio.v3 as iio
import numpy as np
import pandas as pd
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from test_study_render import _spec, toy_example  # noqa: E402,F401 - the fixture is used by name



def _frames(path: Path) -> np.ndarray:
    """Every frame of a video, or the one image of a poster/filmstrip, as a uint8 array."""
    return np.asarray(iio.imread(path, index=None) if path.suffix == ".mp4" else iio.imread(path))


@pytest.mark.slow
def test_stimuli_rendered_on_dask_workers_equal_those_rendered_in_process(tmp_path, toy_example):  # noqa: F811
    from mocomp.plots.render3d import configure_offscreen
    from study.render import render_stimulus_set

    configure_offscreen(None)
    spec = _spec(tmp_path)
    local = render_stimulus_set(spec, tmp_path / "local", progress=False)
    dask = render_stimulus_set(spec, tmp_path / "dask", progress=False, workers=2)
    assert dask.rendered == local.rendered and len(dask.rendered) == 4
    # same stimuli, same measures (to a tolerance: a worker's BLAS threads may change the last bits),
    # same pictures (pixels within 2 levels; encoded bytes and hashes are not compared)
    a, b = (r.manifest.drop(columns=["render_s", "sha256"]) for r in (local, dask))
    pd.testing.assert_frame_equal(a, b, check_exact=False, rtol=1e-9, atol=1e-12)
    for col in ("file", "poster", "filmstrip"):
        for rel in a[col]:
            fa, fb = _frames(tmp_path / "local" / rel), _frames(tmp_path / "dask" / rel)
            assert fa.shape == fb.shape, rel
            assert np.abs(fa.astype(int) - fb.astype(int)).max() <= 2, rel
    # unchanged on the second run, whichever way it runs
    again = render_stimulus_set(spec, tmp_path / "dask", progress=False, workers=2)
    assert again.rendered == [] and len(again.skipped) == 4
