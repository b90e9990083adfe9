"""The perception study: stimuli, rendering, trial design, harness, analysis.

Modules: :mod:`study.stimulus_set` (manifest reader), :mod:`study.design`
(per-participant plans), :mod:`study.session` (crash-safe session storage and
its lock), :mod:`study.harness` (the ipywidgets app and the trial controller
it shares with simulated observers), :mod:`study.observers`,
:mod:`study.analysis`, :mod:`study.paper` (the published Table 2),
:mod:`study.placeholders` (synthetic pilot videos). Heavy imports (widgets,
statsmodels) happen only in the modules that need them.
"""
__version__ = "0.1.0"
