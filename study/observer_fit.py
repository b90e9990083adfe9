"""Maximum-likelihood fit of the simulated-observer model, with calibrated confidence intervals.

Model (:mod:`study.observers`): for error type s at level x,

    P("incorrect" | s, x) = lapse / 2 + (1 - lapse) * Phi((x / threshold_s) ** slope_s - bias)

and P("incorrect" | unperturbed) = lapse / 2 + (1 - lapse) * Phi(-bias). The
parameters are estimated on working scales (log threshold, log slope, the bias
itself, the lapse rate itself constrained to [0, ``max_lapse``]) by minimising
the binomial negative log-likelihood of the counts per cell with its analytic
gradient (scipy L-BFGS-B, two starting lapse values).

Confidence intervals
--------------------
Wald intervals (estimate +- z SE from the Hessian) are poorly calibrated here:
the lapse rate is weakly identified and often sits on its boundary (0), where
the Hessian is singular, and it trades off against the slopes and the bias,
so the likelihood is far from quadratic. Over simulated cohorts like the one
in ``tests/test_study_observers.py`` the Wald intervals of the earlier
implementation covered about 84 % of the generating parameters instead of 95 %
(whole fits failed with NaN SEs when the lapse went to 0).

The default, ``ci_method="profile"``, inverts the likelihood-ratio test: the
interval of parameter j holds every value v with
``2 [l(theta_hat) - max_{theta: theta_j = v} l(theta)] <= chi2_1(ci)``
(profile likelihood; e.g. Venzon & Moolgavkar 1988, Pawitan 2001 ch. 3). It
is invariant to the working scale, respects the bounds (a lapse estimated at 0
gets a lower limit of 0), and needs no Hessian. Where the profile never reaches
the cut-off before a bound of the working scale (a parameter the data cannot
bound), the limit is reported as that bound (``inf`` for thresholds and slopes)
and flagged in ``ci_note``. Coverage is checked by simulation in
``tests/test_study_observers.py``.

``ci_method="bootstrap"`` resamples *participants* (a cluster bootstrap,
seeded): it stays honest when participants differ from one another, which the
pooled likelihood ignores (the profile and Wald intervals assume one observer
model for the whole cohort). ``"wald"`` is kept for comparison.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from scipy.optimize import minimize
from scipy.special import ndtr
from scipy.stats import chi2, norm

__all__ = ["ObserverFit", "ObserverCells", "observer_cells", "fit_observer_model", "CI_METHODS"]

CI_METHODS = ("profile", "bootstrap", "wald")
_LOG_SLOPE_BOUNDS = (np.log(0.05), np.log(20.0))
_BIAS_BOUNDS = (-6.0, 6.0)


@dataclass(frozen=True)
class ObserverCells:
    """Test trials aggregated to binomial counts per (group, error type, level) and participant.

    ``k``/``n``: "incorrect" answers / trials per row; ``x``: level; ``s_idx``:
    error-type index (-1 for unperturbed motions); ``g_idx``: criterion index;
    ``p_idx``: participant index (for the cluster bootstrap); ``series``:
    ``(perturbation, direction)`` per index; ``groups``: criterion names.
    """

    k: np.ndarray
    n: np.ndarray
    x: np.ndarray
    s_idx: np.ndarray
    g_idx: np.ndarray
    p_idx: np.ndarray
    series: list
    groups: list
    participants: list

    def pooled(self, weights: np.ndarray | None = None) -> "ObserverCells":
        """Counts summed over participants (``weights``: how often each participant is drawn)."""
        w = np.ones(len(self.participants)) if weights is None else np.asarray(weights, float)
        key = np.stack([self.s_idx, self.g_idx, self.x], axis=1)
        uniq, inv = np.unique(key, axis=0, return_inverse=True)
        inv = inv.ravel()
        k = np.bincount(inv, weights=self.k * w[self.p_idx], minlength=len(uniq))
        n = np.bincount(inv, weights=self.n * w[self.p_idx], minlength=len(uniq))
        keep = n > 0
        return ObserverCells(k[keep], n[keep], uniq[keep, 2], uniq[keep, 0].astype(int), uniq[keep, 1].astype(int),
                             np.zeros(int(keep.sum()), int), self.series, self.groups, ["(pooled)"])


def observer_cells(data, *, level: str = "nominal_level", criterion: str = "shared") -> ObserverCells:
    """Aggregate the test trials of ``data`` (ResponseData or a trials DataFrame)."""
    trials = data.test if hasattr(data, "test") else data[data["kind"] == "test"]
    if criterion not in ("shared", "group"):
        raise ValueError("criterion must be 'shared' or 'group'")
    if not len(trials):
        raise ValueError("no test trials to fit")
    t = trials.assign(x=trials[level].astype(float))
    if "participant_id" not in t.columns:
        t = t.assign(participant_id="(all)")
    agg = (t.groupby(["participant_id", "group", "perturbation", "direction", "x"])["incorrect"]
           .agg(["sum", "size"]).reset_index())
    pert = agg[agg["perturbation"] != "none"]
    if not len(pert):
        raise ValueError("no perturbed test trials to fit")
    if not (agg["perturbation"] == "none").any():
        raise ValueError("no unperturbed test trials: the criterion (bias) needs them")
    if (pert["x"] <= 0).any():
        raise ValueError(f"perturbed trials need a level > 0 in column {level!r}")
    series = sorted({(p, d) for p, d in zip(pert["perturbation"], pert["direction"])})
    groups = sorted(agg["group"].unique()) if criterion == "group" else ["(all)"]
    parts = sorted(agg["participant_id"].unique())
    s_idx = np.array([series.index((p, d)) if p != "none" else -1
                      for p, d in zip(agg["perturbation"], agg["direction"])])
    g_idx = np.array([groups.index(g) for g in agg["group"]]) if criterion == "group" else np.zeros(len(agg), int)
    p_idx = agg["participant_id"].map({p: i for i, p in enumerate(parts)}).to_numpy()
    return ObserverCells(agg["sum"].to_numpy(float), agg["size"].to_numpy(float), agg["x"].to_numpy(float),
                         s_idx, g_idx, p_idx, series, groups, parts)


class _Likelihood:
    """Negative log-likelihood and gradient on the working scale (see the module docstring)."""

    def __init__(self, cells: ObserverCells, fit_lapse: bool, lapse: float):
        c = cells.pooled()
        self.k, self.n, self.x = c.k, c.n, c.x
        self.s, self.g = c.s_idx, c.g_idx
        self.G, self.S = len(cells.groups), len(cells.series)
        self.fit_lapse = fit_lapse
        self.fixed_lapse = float(lapse)
        self.m = self.s >= 0
        self.lx = np.log(np.where(self.m, self.x, 1.0))
        self.dim = self.G + 2 * self.S + int(fit_lapse)
        # a constant making the deviance comparable across fits (binomial coefficients)
        from scipy.special import gammaln

        self.const = float(np.sum(gammaln(self.n + 1) - gammaln(self.k + 1) - gammaln(self.n - self.k + 1)))

    def split(self, th):
        G, S = self.G, self.S
        lam = th[-1] if self.fit_lapse else self.fixed_lapse
        return th[:G], th[G:G + S], th[G + S:G + 2 * S], lam

    def __call__(self, th):
        b, lt, ls, lam = self.split(th)
        m, s = self.m, self.s
        beta = np.exp(ls)
        dp = np.zeros_like(self.x)
        e = np.zeros_like(self.x)
        e[m] = beta[s[m]] * (self.lx[m] - lt[s[m]])
        dp[m] = np.exp(np.minimum(e[m], 50.0))
        z = dp - b[self.g]
        Phi = ndtr(z)  # (scipy.stats.norm carries ~50 us of overhead per call)
        p = lam / 2 + (1 - lam) * Phi
        p = np.clip(p, 1e-15, 1 - 1e-15)
        k, n = self.k, self.n
        f = -float(np.sum(k * np.log(p) + (n - k) * np.log1p(-p)))
        dl_dp = -(k / p - (n - k) / (1 - p))  # d(-l)/dp
        dp_dz = (1 - lam) * np.exp(-0.5 * z * z) / np.sqrt(2 * np.pi)
        gz = dl_dp * dp_dz
        grad = np.zeros(self.dim)
        G, S = self.G, self.S
        grad[:G] = -np.bincount(self.g, weights=gz, minlength=G)
        gm = gz[m] * dp[m]
        grad[G:G + S] = np.bincount(s[m], weights=-gm * beta[s[m]], minlength=S)
        grad[G + S:G + 2 * S] = np.bincount(s[m], weights=gm * e[m], minlength=S)
        if self.fit_lapse:
            grad[-1] = float(np.sum(dl_dp * (0.5 - Phi)))
        return f, grad

    def probs(self, th):
        b, lt, ls, lam = self.split(th)
        dp = np.zeros_like(self.x)
        m, s = self.m, self.s
        dp[m] = (self.x[m] / np.exp(lt[s[m]])) ** np.exp(ls[s[m]])
        return lam / 2 + (1 - lam) * norm.cdf(dp - b[self.g])


def _bounds(cells: ObserverCells, fit_lapse: bool, max_lapse: float) -> list[tuple[float, float]]:
    xpos = cells.x[cells.s_idx >= 0]
    lt = (float(np.log(xpos.min() / 1000.0)), float(np.log(xpos.max() * 1000.0)))
    G, S = len(cells.groups), len(cells.series)
    return [_BIAS_BOUNDS] * G + [lt] * S + [_LOG_SLOPE_BOUNDS] * S + ([(0.0, max_lapse)] if fit_lapse else [])


def _starts(L: _Likelihood, cells: ObserverCells, fit_lapse: bool) -> list[np.ndarray]:
    ctl = L.s < 0
    f0 = (L.k[ctl].sum() + 0.5) / (L.n[ctl].sum() + 1)
    th = [float(-norm.ppf(f0))] * L.G
    for j in range(L.S):
        th.append(float(np.log(np.median(L.x[L.s == j]))))
    th += [float(np.log(1.5))] * L.S
    base = np.array(th + ([0.0] if fit_lapse else []))
    if not fit_lapse:
        return [base]
    out = []
    for lam in (0.01, 0.1):
        b = base.copy()
        b[-1] = lam
        out.append(b)
    return out


def _minimize(L, x0, bounds, fixed: dict | None = None):
    """Minimise ``L`` over the free parameters (``fixed``: index -> value)."""
    fixed = fixed or {}
    free = np.array([i for i in range(L.dim) if i not in fixed], int)
    full = np.asarray(x0, float).copy()
    for i, v in fixed.items():
        full[i] = v

    def fun(xf):
        full[free] = xf
        f, g = L(full)
        return f, g[free]

    x_init = np.clip(full[free], [bounds[i][0] for i in free], [bounds[i][1] for i in free])
    res = minimize(fun, x_init, jac=True, method="L-BFGS-B", bounds=[bounds[i] for i in free],
                   options=dict(maxiter=3000, ftol=1e-12, gtol=1e-7))
    full[free] = res.x
    return full.copy(), float(res.fun), bool(res.success or "REL_REDUCTION" in str(res.message))


def _fit(L: _Likelihood, cells, fit_lapse, bounds):
    best = None
    for x0 in _starts(L, cells, fit_lapse):
        th, f, ok = _minimize(L, x0, bounds)
        if best is None or f < best[1] - 1e-9:
            best = (th, f, ok)
    return best


def _hessian(L, th, bounds) -> np.ndarray:
    """Central differences of the analytic gradient; parameters at a bound are left out (NaN rows)."""
    d = L.dim
    H = np.full((d, d), np.nan)
    inside = [i for i in range(d) if bounds[i][0] + 1e-6 < th[i] < bounds[i][1] - 1e-6]
    for i in inside:
        h = 1e-5 * max(1.0, abs(th[i]))
        tp, tm = th.copy(), th.copy()
        tp[i] += h
        tm[i] -= h
        H[i] = (L(tp)[1] - L(tm)[1]) / (2 * h)
    sub = np.ix_(inside, inside)
    Hs = H[sub]
    Hs = 0.5 * (Hs + Hs.T)
    cov = np.full((d, d), np.nan)
    try:
        cov[sub] = np.linalg.inv(Hs)
    except np.linalg.LinAlgError:
        pass
    return cov


def _illinois(r, a, fa, b, fb, tol: float = 1e-3, maxiter: int = 40) -> float:
    """Root of ``r`` in the bracket ``[a, b]`` (``fa < 0 <= fb``) by the Illinois false-position method.

    The signed root deviance is nearly linear in the parameter, so this converges in a few
    steps; the bracket values are reused, never recomputed (the profile is an inner
    optimisation, and a re-evaluation from another warm start may differ in the last digits).
    """
    for _ in range(maxiter):
        c = b - fb * (b - a) / (fb - fa)
        fc = r(c)
        if abs(fc) < tol or abs(b - a) < 1e-7 * max(1.0, abs(c)):
            return c
        if (fc < 0) == (fb < 0):
            fa *= 0.5
        else:
            a, fa = b, fb
        b, fb = c, fc
    return c


def _profile_limits(L, th_hat, f_hat, j, bounds, se_j, ci) -> tuple[float, float, str]:
    """Both limits of the profile-likelihood interval of working parameter ``j``."""
    zc = float(np.sqrt(chi2.ppf(ci, 1)))
    lo_b, hi_b = bounds[j]
    notes = []
    limits = []
    for side in (-1.0, 1.0):
        v0 = th_hat[j]
        bound = lo_b if side < 0 else hi_b
        if abs(v0 - bound) < 1e-9:
            limits.append(bound)
            continue
        warm = [th_hat]

        def r(v):
            th, f, _ = _minimize(L, warm[0], bounds, {j: v})
            warm[0] = th
            return np.sqrt(max(2.0 * (f - f_hat), 0.0)) - zc

        step = zc * se_j if np.isfinite(se_j) and se_j > 0 else 0.25 * max(1.0, abs(v0))
        if j == L.dim - 1 and L.fit_lapse and not (np.isfinite(se_j) and se_j > 0):
            step = 0.02
        prev, val = v0, -zc
        found = None
        for _ in range(40):
            v = v0 + side * step
            v = min(max(v, lo_b), hi_b)
            rv = r(v)
            if rv >= 0:
                found = _illinois(r, prev, val, v, rv)
                break
            if v in (lo_b, hi_b):
                break
            prev, val = v, rv
            step *= 1.6
        if found is None:
            which = "lower" if side < 0 else "upper"
            if L.fit_lapse and j == L.dim - 1:  # the lapse rate's own range [0, max_lapse]
                notes.append(f"{which} limit at the bound lapse = {bound:g}")
            else:
                notes.append(f"{which} limit not bounded by the data")
            limits.append(bound)
        else:
            limits.append(found)
    return limits[0], limits[1], "; ".join(notes)


@dataclass
class ObserverFit:
    """Maximum-likelihood estimates of the observer model.

    ``params``: one row per parameter: ``name`` (bias, threshold, slope,
    lapse), ``series`` (error type, or the group for a per-group criterion),
    ``estimate``, ``ci_low``, ``ci_high`` (natural scale), ``se`` (Wald SE on
    the working scale: log for threshold/slope, identity for bias and lapse;
    NaN at a bound), ``transform``, ``ci_method``, ``ci_note`` (e.g. a limit
    the data do not bound). ``observer``: the fitted :class:`~study.observers.Observer`
    (a per-group criterion is collapsed to the first group). ``loglike``
    (binomial, with coefficients), ``converged``, ``deviance`` (against the
    saturated model of the pooled cells) and ``df_resid``; ``settings``: how
    it was fitted (ci, method, bootstrap size, seed, failed resamples).
    """

    params: pd.DataFrame
    observer: object
    loglike: float
    converged: bool
    deviance: float = float("nan")
    df_resid: int = 0
    settings: dict = field(default_factory=dict)

    def _row(self, name: str, series: str):
        r = self.params[(self.params["name"] == name) & (self.params["series"] == series)]
        if not len(r):
            raise KeyError(f"no parameter {name!r} for series {series!r}")
        return r.iloc[0]

    def value(self, name: str, series: str = "") -> float:
        return float(self._row(name, series)["estimate"])

    def contains(self, name: str, value: float, series: str = "") -> bool:
        r = self._row(name, series)
        return bool(r["ci_low"] <= value <= r["ci_high"])


def fit_observer_model(data, *, level: str = "nominal_level", criterion: str = "shared", fit_lapse: bool = True,
                       lapse: float = 0.0, max_lapse: float = 0.5, ci: float = 0.95, ci_method: str = "profile",
                       n_boot: int = 500, seed: int = 0, progress: bool = False) -> ObserverFit:
    """Fit threshold and slope per error type, the criterion and the lapse rate (module docstring).

    Parameters
    ----------
    data: a :class:`study.analysis.ResponseData` or a trials DataFrame (test trials are used).
    level: the regressor column (``nominal_level`` or ``achieved_error``).
    criterion: ``"shared"`` (one bias) or ``"group"`` (one per error group).
    fit_lapse: estimate the lapse rate in [0, ``max_lapse``]; otherwise it is fixed at ``lapse``.
    ci: confidence level; ``ci_method``: ``"profile"`` (default), ``"bootstrap"``
        (participants resampled ``n_boot`` times, percentile intervals, ``seed``) or ``"wald"``.

    Assumes d' grows with the level (sign +1) and that every participant follows the
    same model (the pooled likelihood); use ``"bootstrap"`` when participants differ.
    """
    from threadpoolctl import threadpool_limits

    # the optimiser makes many tiny BLAS calls: threads only add synchronisation
    # (10x slower on a loaded 2-core machine)
    with threadpool_limits(limits=1, user_api="blas"):
        return _fit_observer_model(data, level=level, criterion=criterion, fit_lapse=fit_lapse, lapse=lapse,
                                   max_lapse=max_lapse, ci=ci, ci_method=ci_method, n_boot=n_boot, seed=seed,
                                   progress=progress)


def _fit_observer_model(data, *, level, criterion, fit_lapse, lapse, max_lapse, ci, ci_method, n_boot, seed,
                        progress) -> ObserverFit:
    from .observers import Observer, Psychometric

    if ci_method not in CI_METHODS:
        raise ValueError(f"ci_method must be one of {CI_METHODS}, got {ci_method!r}")
    if not 0 < ci < 1:
        raise ValueError(f"ci must be in (0, 1), got {ci}")
    if not 0 < max_lapse < 1:
        raise ValueError(f"max_lapse must be in (0, 1), got {max_lapse}")
    cells = observer_cells(data, level=level, criterion=criterion)
    bounds = _bounds(cells, fit_lapse, max_lapse)
    L = _Likelihood(cells, fit_lapse, lapse)
    th, f_hat, ok = _fit(L, cells, fit_lapse, bounds)
    cov = _hessian(L, th, bounds)
    se = np.sqrt(np.where(np.diag(cov) > 0, np.diag(cov), np.nan))
    G, S = L.G, L.S
    lo = np.full(L.dim, np.nan)
    hi = np.full(L.dim, np.nan)
    notes = [""] * L.dim
    extra = {}
    if ci_method == "wald":
        zc = norm.ppf(0.5 + ci / 2)
        lo = np.maximum(th - zc * se, [b[0] for b in bounds])
        hi = np.minimum(th + zc * se, [b[1] for b in bounds])
        for j in range(L.dim):
            if not np.isfinite(se[j]):
                notes[j] = "Wald SE undefined (estimate at a bound or singular Hessian)"
    elif ci_method == "profile":
        for j in range(L.dim):
            lo[j], hi[j], notes[j] = _profile_limits(L, th, f_hat, j, bounds, se[j], ci)
    else:
        rng = np.random.default_rng(seed)
        P = len(cells.participants)
        if P < 2:
            raise ValueError("ci_method='bootstrap' resamples participants; the data have only one")
        W = rng.multinomial(P, np.full(P, 1.0 / P), size=int(n_boot))
        boots = []
        failed = 0
        it = range(int(n_boot))
        if progress:
            from tqdm.auto import tqdm

            it = tqdm(it, desc="observer-fit bootstrap", leave=False)
        for b in it:
            cb = cells.pooled(W[b])
            if not np.any(cb.s_idx < 0) or len(set(cb.s_idx[cb.s_idx >= 0])) < S:
                failed += 1
                continue
            Lb = _Likelihood(cb, fit_lapse, lapse)
            thb, _, okb = _minimize(Lb, th, bounds)
            if not okb:
                failed += 1
                continue
            boots.append(thb)
        B = np.array(boots)
        a = (1 - ci) / 2
        lo, hi = np.quantile(B, a, axis=0), np.quantile(B, 1 - a, axis=0)
        extra = dict(n_boot=int(n_boot), seed=int(seed), failed_resamples=failed)
    rows = []
    for j in range(L.dim):
        if j < G:
            rows.append(dict(name="bias", series=cells.groups[j] if criterion == "group" else "", estimate=th[j],
                             ci_low=lo[j], ci_high=hi[j], se=se[j], transform="identity"))
        elif j < G + S:
            p, d = cells.series[j - G]
            ub = np.inf if abs(hi[j] - bounds[j][1]) < 1e-9 else np.exp(hi[j])
            lb = 0.0 if abs(lo[j] - bounds[j][0]) < 1e-9 else np.exp(lo[j])
            rows.append(dict(name="threshold", series=f"{p}/{d}", estimate=np.exp(th[j]), ci_low=lb, ci_high=ub,
                             se=se[j], transform="log"))
        elif j < G + 2 * S:
            p, d = cells.series[j - G - S]
            ub = np.inf if abs(hi[j] - bounds[j][1]) < 1e-9 else np.exp(hi[j])
            lb = 0.0 if abs(lo[j] - bounds[j][0]) < 1e-9 else np.exp(lo[j])
            rows.append(dict(name="slope", series=f"{p}/{d}", estimate=np.exp(th[j]), ci_low=lb, ci_high=ub,
                             se=se[j], transform="log"))
        else:
            rows.append(dict(name="lapse", series="", estimate=th[j], ci_low=lo[j], ci_high=hi[j], se=se[j],
                             transform="identity"))
        rows[-1].update(ci_method=ci_method, ci_note=notes[j])
    params = pd.DataFrame(rows)
    psy = {s: Psychometric(threshold=float(np.exp(th[G + j])), slope=float(np.exp(th[G + S + j])))
           for j, s in enumerate(cells.series)}
    obs = Observer(psychometric=psy, bias=float(th[0]), lapse=float(th[-1]) if fit_lapse else float(lapse))
    # deviance against the saturated model of the pooled cells
    p = np.clip(L.probs(th), 1e-15, 1 - 1e-15)
    with np.errstate(divide="ignore", invalid="ignore"):
        ph = L.k / L.n
        sat = np.where(L.k > 0, L.k * np.log(np.where(ph > 0, ph, 1)), 0) + \
            np.where(L.n - L.k > 0, (L.n - L.k) * np.log(np.where(ph < 1, 1 - ph, 1)), 0)
        mod = L.k * np.log(p) + (L.n - L.k) * np.log1p(-p)
    dev = float(2 * np.sum(sat - mod))
    settings = dict(ci=ci, ci_method=ci_method, level=level, criterion=criterion, fit_lapse=fit_lapse,
                    max_lapse=max_lapse, n_participants=len(cells.participants), **extra)
    return ObserverFit(params=params, observer=obs, loglike=-f_hat + L.const, converged=ok, deviance=dev,
                       df_resid=int(len(L.k) - L.dim), settings=settings)
