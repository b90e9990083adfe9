"""Simulated observers, and the fit that recovers their parameters.

Observer model (signal detection with a power-law transducer and lapses).
For a motion of error type s (perturbation x direction) at level x the
observer perceives evidence e ~ N(d'_s(x), 1) with

    d'_s(x) = sign_s * (x / threshold_s) ** slope_s        (d'_s(0) = 0)

and answers "incorrect" when e > bias (the criterion, in z units). With
probability ``lapse`` the observer does not attend and guesses (50/50). So

    P("incorrect" | s, x) = lapse / 2 + (1 - lapse) * Phi(d'_s(x) - bias)

``threshold`` is the level at which d' = 1 (before lapses), ``slope`` the
exponent (steepness), ``bias`` > 0 favours "correct" (the paper's controls
were rated correct 72 % of the time, bias = z(0.72) = 0.58 without lapses),
``lapse`` the proportion of random answers. On attention checks an attentive
observer presses the instructed button.

Simulated observers answer through the same code path as people
(:class:`study.controller.TrialController` over a :class:`study.session.Session`,
writing the same CSV); only the source of the answer differs.
:func:`fit_observer_model` (:mod:`study.observer_fit`) estimates (threshold,
slope per error type; bias; lapse) by maximum likelihood, with
profile-likelihood confidence intervals by default (Wald intervals are badly
calibrated for this model, see that module) or a participant bootstrap.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.stats import norm

from .controller import TrialController, TrialView, run_headless
from .design import DesignConfig
from .session import Session
from .stimulus_set import StimulusSet


@dataclass(frozen=True)
class Psychometric:
    """d'(x) = sign * (x / threshold) ** slope for one error type."""

    threshold: float
    slope: float = 1.0
    sign: float = 1.0

    def __post_init__(self):
        if not (self.threshold > 0 and self.slope > 0):
            raise ValueError(f"threshold and slope must be > 0, got {self.threshold}, {self.slope}")
        if self.sign not in (1.0, -1.0, 1, -1):
            raise ValueError("sign must be +1 or -1")

    def dprime(self, x):
        x = np.asarray(x, float)
        return self.sign * (np.maximum(x, 0.0) / self.threshold) ** self.slope


@dataclass(frozen=True)
class Observer:
    """A simulated participant (see the module docstring).

    ``psychometric`` maps ``(perturbation, direction)`` to a
    :class:`Psychometric`; error types not listed are undetectable (d' = 0).
    ``rt_median_s``/``rt_sigma``: log-normal response times.
    """

    psychometric: dict = field(default_factory=dict)
    bias: float = 0.5
    lapse: float = 0.0
    rt_median_s: float = 1.2
    rt_sigma: float = 0.3

    def __post_init__(self):
        if not 0 <= self.lapse < 1:
            raise ValueError(f"lapse must be in [0, 1), got {self.lapse}")

    def true_dprime(self, perturbation: str, direction: str, level) -> np.ndarray:
        """d' of the perception model (no lapses)."""
        if perturbation == "none":
            return np.zeros_like(np.asarray(level, float))
        ps = self.psychometric.get((perturbation, direction))
        return np.zeros_like(np.asarray(level, float)) if ps is None else ps.dprime(level)

    def p_incorrect(self, perturbation: str, direction: str, level) -> np.ndarray:
        d = self.true_dprime(perturbation, direction, level)
        return self.lapse / 2 + (1 - self.lapse) * norm.cdf(d - self.bias)

    def expected_dprime(self, perturbation: str, direction: str, level) -> np.ndarray:
        """The d' an analysis of this observer's answers converges to (lapses included)."""
        return norm.ppf(self.p_incorrect(perturbation, direction, level)) - norm.ppf(
            self.p_incorrect("none", "none", 0.0))

    def respond(self, view: TrialView, rng: np.random.Generator) -> tuple[str, float]:
        """Answer one trial: ("correct" | "incorrect", response time in s)."""
        rt = float(self.rt_median_s * np.exp(self.rt_sigma * rng.standard_normal()))
        if view.kind == "attention":
            if rng.random() >= self.lapse:
                return view.expected_response, rt
            return ("correct", "incorrect")[int(rng.integers(2))], rt
        m = view.meta
        p = float(self.p_incorrect(m["perturbation"], m["direction"], float(m["nominal_level"])))
        return ("incorrect" if rng.random() < p else "correct"), rt


def simulate_cohort(stimuli: StimulusSet, observers: list[Observer] | Observer, data_dir: str | Path, *,
                    n: int | None = None, design: DesignConfig | None = None, study_seed: int = 0,
                    session_id: str = "S1", prefix: str = "SIM", seed: int = 0, progress: bool = False) -> list[Path]:
    """Run simulated participants through plan -> controller -> responses CSV.

    ``observers``: one per participant, or a single observer repeated ``n``
    times. Participant ids are ``{prefix}{i:03d}``; each gets its own plan
    (seed from ``study_seed`` and the id, as for people) and its answers come
    from ``np.random.default_rng([seed, i])``. Returns the session folders.
    """
    obs = [observers] * int(n) if isinstance(observers, Observer) else list(observers)
    if not obs:
        raise ValueError("no observers")
    folders = []
    it = range(len(obs))
    if progress:
        from tqdm.auto import tqdm

        it = tqdm(it, desc="simulated participants")
    for i in it:
        pid = f"{prefix}{i:03d}"
        rng = np.random.default_rng([int(seed), i])
        sess = Session.open(data_dir, pid, session_id, stimuli, config=design, study_seed=study_seed)
        ctl = TrialController(sess)
        ob = obs[i]
        run_headless(ctl, lambda v, ob=ob, rng=rng: ob.respond(v, rng))
        folders.append(sess.folder)
    return folders


# --------------------------------------------------------------------- fitting
# The fit lives in study.observer_fit (likelihood, profile-likelihood / bootstrap CIs);
# re-exported here, where the observer model is defined.
from .observer_fit import ObserverFit, fit_observer_model  # noqa: E402


def simulate_responses(stimuli: StimulusSet, observers: list[Observer] | Observer, *, n: int | None = None,
                       design: DesignConfig | None = None, session_id: str = "S1", prefix: str = "SIM",
                       seed: int = 0, n_done: np.ndarray | list | None = None) -> pd.DataFrame:
    """Responses of many simulated participants at once, as the rows of their ``responses.csv`` files.

    The fast path for large cohorts (benchmarks, scaling tests): it does not run the
    harness (:func:`simulate_cohort` does, 0.1-0.3 s per participant). One plan is
    made with :func:`study.design.make_plan` (participant ``{prefix}000``'s seed);
    every participant answers its response trials in an order of their own (a
    random permutation, seeded by ``seed``), with the observer model of the module
    docstring (attention checks: the instructed answer, or a guess with probability
    ``lapse``), log-normal response times. ``observers``: one per participant, or
    one repeated ``n`` times. ``n_done``: trials answered per participant (a
    session stopped early keeps its first ``n_done[i]`` rows); default all.
    Columns: :data:`study.session.RESPONSE_COLUMNS` (times in ``shown_utc`` /
    ``responded_utc`` left empty), in trial order per participant.
    """
    from .design import make_plan, participant_seed
    from .session import RESPONSE_COLUMNS

    obs = list(observers) if isinstance(observers, (list, tuple)) else [observers] * int(n or 1)
    if not obs:
        raise ValueError("no observers")
    P = len(obs)
    plan = make_plan(stimuli, design, participant_id=f"{prefix}000", seed=participant_seed(0, f"{prefix}000"))
    rt_tab = plan.response_trials.reset_index(drop=True)
    T = len(rt_tab)
    rng = np.random.default_rng(seed)
    order = np.argsort(rng.random((P, T)), axis=1)  # (P, T): which plan row each position shows
    pert = rt_tab["perturbation"].to_numpy(object)
    dirs = rt_tab["direction"].to_numpy(object)
    lev = rt_tab["nominal_level"].to_numpy(float)
    kind = rt_tab["kind"].to_numpy(object)
    expected = rt_tab["expected_response"].fillna("").to_numpy(object)
    # P(incorrect) per (observer, plan row); identical observers share one row of probabilities
    cache: dict[int, np.ndarray] = {}
    pinc = np.empty((P, T))
    for i, ob in enumerate(obs):
        key = id(ob)
        if key not in cache:
            cache[key] = np.array([float(ob.p_incorrect(p, d, x)) for p, d, x in zip(pert, dirs, lev)])
        pinc[i] = cache[key]
    lapse = np.array([ob.lapse for ob in obs])[:, None]
    u = rng.random((P, T))
    p_shown = np.take_along_axis(pinc, order, axis=1)
    incorrect = u < p_shown
    is_att = (kind == "attention")[order]
    if is_att.any():
        guess = rng.random((P, T)) < lapse
        coin = rng.random((P, T)) < 0.5
        exp_inc = (expected == "incorrect")[order]
        incorrect = np.where(is_att, np.where(guess, coin, exp_inc), incorrect)
    med = np.array([ob.rt_median_s for ob in obs])[:, None]
    sig = np.array([ob.rt_sigma for ob in obs])[:, None]
    rt = med * np.exp(sig * rng.standard_normal((P, T)))
    done = np.full(P, T) if n_done is None else np.asarray(n_done, int)
    if done.shape != (P,) or np.any((done < 0) | (done > T)):
        raise ValueError(f"n_done must give 0..{T} answered trials for each of the {P} participants")
    keep = (np.arange(T)[None, :] < done[:, None]).ravel()
    flat = order.ravel()[keep]
    pid = np.repeat(np.array([f"{prefix}{i:03d}" for i in range(P)], object), T)[keep]
    resp = np.where(incorrect.ravel()[keep], "incorrect", "correct")
    out = {c: np.full(len(flat), "", object) for c in RESPONSE_COLUMNS}
    out.update(participant_id=pid, session_id=session_id, stimulus_set_id=plan.meta["stimulus_set_id"],
               plan_sha256=plan.sha256, seed=str(plan.meta["seed"]),
               trial_index=rt_tab["trial_index"].to_numpy()[flat], response=resp,
               rated_correct=(resp == "correct").astype(int), input="observer", must_watch=0,
               rt_s=np.round(rt.ravel()[keep], 4))
    for c in ("kind", "group", "repetition", "stimulus_id", "condition", "perturbation", "direction",
              "nominal_level", "base_clip", "expected_response"):
        out[c] = rt_tab[c].to_numpy()[flat]
    out["achieved_error"] = stimuli.table["achieved_error"].reindex(out["stimulus_id"]).to_numpy()
    # rows in the order each participant answered (trial_index is the plan row, as in real files)
    return pd.DataFrame(out, columns=list(RESPONSE_COLUMNS))


def write_responses(df: pd.DataFrame, data_dir: str | Path) -> list[Path]:
    """Write :func:`simulate_responses` rows as ``DATA/<participant>/<session>/responses.csv`` files."""
    folders = []
    for (pid, sid), sub in df.groupby(["participant_id", "session_id"], sort=True):
        f = Path(data_dir) / str(pid) / str(sid)
        f.mkdir(parents=True, exist_ok=True)
        sub.to_csv(f / "responses.csv", index=False, lineterminator="\n")
        folders.append(f)
    return folders
