"""The perception study of the flips paper (section 7, Table 2; dissertation 5.7).

Stimuli, offscreen rendering, trial design, the participant app, analysis.
Modules, in pipeline order:

Stimuli and rendering
    :mod:`study.spec` -- stimulus-set specifications (``stimuli/*.toml``), validated.
    :mod:`study.perturb` -- the perturbed flights: retimed (angular-momentum errors,
    abrupt and smooth) and relaunched (take-off-angle errors), COM parabola re-fitted.
    :mod:`study.stimuli` -- base motions (load, find the flight, normalise), every
    stimulus of a spec, and the achieved errors measured with ``mocomp.dynamics``.
    :mod:`study.render` -- offscreen rendering of a set: MP4, poster, filmstrip,
    ``manifest.csv`` with content hashes (incremental re-rendering).
    :mod:`study.render_cli` -- ``mocomp study render SPEC -o DIR``.
    :mod:`study.stimulus_set` -- the manifest reader (:class:`~study.stimulus_set.StimulusSet`)
    that the design, the app and the analysis see.
    :mod:`study.placeholders` -- tiny synthetic videos with a valid manifest, for pilots and tests.

Running participants
    :mod:`study.design` -- per-participant plans (examples first, random within error
    groups, interleaved, each motion twice; seeds, counterbalancing, practice,
    attention checks, breaks, "must watch first").
    :mod:`study.session` -- crash-safe session folders (plan before the first trial,
    fsync-ed appends, resume, lock).
    :mod:`study.controller` -- the one code path every answer takes (app and simulated observers).
    :mod:`study.harness` -- the ipywidgets app (Jupyter, or Voila via ``mocomp study run``).
    :mod:`study.study_cli` -- ``mocomp study run`` and ``mocomp study analyze``.

Analysis
    :mod:`study.sdt` -- d', its corrections for rates of 0 and 1, ceilings, Wilson intervals.
    :mod:`study.analysis` -- schema-checked loading of every session CSV, condition
    table, per-participant d', psychometric GLMs, mixed model, report.
    :mod:`study.glmm` -- maximum-likelihood logistic GLMM with a random intercept
    (adaptive Gauss-Hermite quadrature).
    :mod:`study.plots` -- the analysis figures (matplotlib).
    :mod:`study.paper` -- the published Table 2 and its d' recomputed from the ratings.
    :mod:`study.observers` -- simulated observers answering through the controller.
    :mod:`study.observer_fit` -- maximum-likelihood fit of the observer model with
    profile-likelihood (or participant-bootstrap) confidence intervals.

The data written per session are described in ``study/DATA_DICTIONARY.md``; the
stimulus method and the manifest columns in ``stimuli/README.md``. Heavy imports
(widgets, statsmodels, VTK) happen only in the modules that need them.
"""
__version__ = "0.2.0"
