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
:func:`fit_observer_model` estimates (threshold, slope per error type; bias;
lapse) by maximum likelihood (statsmodels ``GenericLikelihoodModel``) with
Wald CIs on the log / logit scales mapped back.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.special import expit, logit
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
@dataclass
class ObserverFit:
    """Maximum-likelihood estimates of the observer model.

    ``params``: one row per parameter (name, series, estimate, ci_low,
    ci_high, se of the transformed parameter, transform). ``observer``: the
    fitted :class:`Observer` (criterion per group collapsed to the first group
    when ``criterion="group"``). ``loglike``, ``converged``, ``result`` (the
    statsmodels result).
    """

    params: pd.DataFrame
    observer: Observer
    loglike: float
    converged: bool
    result: object

    def value(self, name: str, series: str = "") -> float:
        r = self.params[(self.params["name"] == name) & (self.params["series"] == series)]
        return float(r["estimate"].iloc[0])

    def contains(self, name: str, value: float, series: str = "") -> bool:
        r = self.params[(self.params["name"] == name) & (self.params["series"] == series)].iloc[0]
        return bool(r["ci_low"] <= value <= r["ci_high"])


def fit_observer_model(data, *, level: str = "nominal_level", criterion: str = "shared", fit_lapse: bool = True,
                       ci: float = 0.95) -> ObserverFit:
    """Fit threshold and slope per error type, bias, and lapse to test trials (all participants pooled).

    ``data``: a :class:`study.analysis.ResponseData` or a trials DataFrame.
    ``criterion``: ``"shared"`` (one bias) or ``"group"`` (one per error group).
    Thresholds and slopes are estimated on the log scale and the lapse on the
    logit scale; their Wald CIs are mapped back (so they are asymmetric).
    Assumes d' grows with the level (sign +1).
    """
    from statsmodels.base.model import GenericLikelihoodModel

    trials = data.test if hasattr(data, "test") else data[data["kind"] == "test"]
    if criterion not in ("shared", "group"):
        raise ValueError("criterion must be 'shared' or 'group'")
    agg = (trials.assign(x=trials[level].astype(float))
           .groupby(["group", "perturbation", "direction", "x"])["incorrect"].agg(["sum", "size"]).reset_index())
    pert = agg[agg["perturbation"] != "none"]
    series = sorted({(p, d) for p, d in zip(pert["perturbation"], pert["direction"])})
    groups = sorted(agg["group"].unique()) if criterion == "group" else ["(all)"]
    s_idx = np.array([series.index((p, d)) if p != "none" else -1 for p, d in zip(agg["perturbation"], agg["direction"])])
    g_idx = np.array([groups.index(g) if criterion == "group" else 0 for g in agg["group"]])
    k = agg["sum"].to_numpy(float)
    n = agg["size"].to_numpy(float)
    x = agg["x"].to_numpy(float)
    S, G = len(series), len(groups)
    names = ([f"bias[{g}]" for g in groups] + [f"log_threshold[{p}/{d}]" for p, d in series]
             + [f"log_slope[{p}/{d}]" for p, d in series] + (["logit_lapse"] if fit_lapse else []))

    def probs(params):
        b = params[:G][g_idx]
        lt = params[G:G + S]
        ls = params[G + S:G + 2 * S]
        lam = expit(params[-1]) if fit_lapse else 0.0
        dp = np.zeros_like(x)
        m = s_idx >= 0
        dp[m] = (np.maximum(x[m], 1e-300) / np.exp(lt[s_idx[m]])) ** np.exp(ls[s_idx[m]])
        p = lam / 2 + (1 - lam) * norm.cdf(dp - b)
        return np.clip(p, 1e-12, 1 - 1e-12)

    class _Model(GenericLikelihoodModel):
        def loglike(self, params):
            p = probs(params)
            return float(np.sum(k * np.log(p) + (n - k) * np.log1p(-p)))

        def nloglikeobs(self, params):
            p = probs(params)
            return -(k * np.log(p) + (n - k) * np.log1p(-p))

    # starting values: bias from the controls, threshold from the middle level, slope 1.5
    ctl = agg["perturbation"] == "none"
    f0 = (k[ctl].sum() + 0.5) / (n[ctl].sum() + 1)
    start = [float(-norm.ppf(f0))] * G
    for p, d in series:
        xs = pert.loc[(pert["perturbation"] == p) & (pert["direction"] == d), "x"]
        start.append(float(np.log(np.median(xs))))
    start += [np.log(1.5)] * S
    if fit_lapse:
        start.append(float(logit(0.03)))
    model = _Model(endog=k, exog=None, extra_params_names=names)
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = model.fit(start_params=np.array(start), method="nm", maxiter=20000, disp=0)
        res = model.fit(start_params=res.params, method="bfgs", maxiter=2000, disp=0)
    est = np.asarray(res.params)
    try:
        se = np.sqrt(np.diag(np.asarray(res.cov_params())))
    except Exception:  # pragma: no cover
        se = np.full(len(est), np.nan)
    zc = norm.ppf(0.5 + ci / 2)
    rows = []
    for i, nm in enumerate(names):
        lo, hi = est[i] - zc * se[i], est[i] + zc * se[i]
        if nm.startswith("bias"):
            rows.append(dict(name="bias", series=nm[5:-1] if criterion == "group" else "", estimate=est[i],
                             ci_low=lo, ci_high=hi, se=se[i], transform="identity"))
        elif nm.startswith("log_threshold"):
            rows.append(dict(name="threshold", series=nm[14:-1], estimate=np.exp(est[i]), ci_low=np.exp(lo),
                             ci_high=np.exp(hi), se=se[i], transform="log"))
        elif nm.startswith("log_slope"):
            rows.append(dict(name="slope", series=nm[10:-1], estimate=np.exp(est[i]), ci_low=np.exp(lo),
                             ci_high=np.exp(hi), se=se[i], transform="log"))
        else:
            rows.append(dict(name="lapse", series="", estimate=expit(est[i]), ci_low=expit(lo), ci_high=expit(hi),
                             se=se[i], transform="logit"))
    params = pd.DataFrame(rows)
    psy = {s: Psychometric(threshold=float(np.exp(est[G + j])), slope=float(np.exp(est[G + S + j])))
           for j, s in enumerate(series)}
    obs = Observer(psychometric=psy, bias=float(est[0]), lapse=float(expit(est[-1])) if fit_lapse else 0.0)
    conv = bool(res.mle_retvals.get("converged", True)) if hasattr(res, "mle_retvals") else True
    return ObserverFit(params=params, observer=obs, loglike=float(res.llf), converged=conv, result=res)
