"""``mocomp study render`` on mocomp.batch's mechanism (issue 20 section 2): stimuli rendered on a
2-worker Dask cluster give the same files (byte for byte) and manifest as in one process."""
from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from test_study_render import _spec, toy_example  # noqa: E402,F401 - the fixture is used by name


@pytest.mark.slow
def test_stimuli_rendered_on_dask_workers_equal_those_rendered_in_process(tmp_path, toy_example):  # noqa: F811
    from mocomp.plots.render3d import configure_offscreen
    from study.render import render_stimulus_set

    configure_offscreen(None)
    spec = _spec(tmp_path)
    local = render_stimulus_set(spec, tmp_path / "local", progress=False)
    dask = render_stimulus_set(spec, tmp_path / "dask", progress=False, workers=2)
    assert dask.rendered == local.rendered and len(dask.rendered) == 4
    a, b = (r.manifest.drop(columns=["render_s"]) for r in (local, dask))
    pd.testing.assert_frame_equal(a, b)  # same sha256 of every video, same measures
    for col in ("poster", "filmstrip"):
        for rel in a[col]:
            assert (tmp_path / "local" / rel).read_bytes() == (tmp_path / "dask" / rel).read_bytes()
    # unchanged on the second run, whichever way it runs
    again = render_stimulus_set(spec, tmp_path / "dask", progress=False, workers=2)
    assert again.rendered == [] and len(again.skipped) == 4
