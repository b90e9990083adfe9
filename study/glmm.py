"""Maximum-likelihood logistic GLMM with one random intercept (adaptive Gauss-Hermite quadrature).

statsmodels offers no frequentist binomial mixed model, and its Bayesian one
(``BinomialBayesMixedGLM``) shrinks large fixed effects through its N(0, 2^2)
prior and fits by variational Bayes, which understates uncertainty. This
module fits the model that lme4's ``glmer(y ~ X + (1 | participant),
family=binomial, nAGQ=k)`` fits:

    logit P(y_ij = 1 | u_i) = x_ij' beta + u_i,   u_i ~ N(0, sigma^2)

by maximising the marginal likelihood, integrating each participant's u_i
with adaptive Gauss-Hermite quadrature (nodes centred at the conditional mode
and scaled by its curvature, Pinheiro & Bates 1995). Standard errors come
from the Hessian of the marginal log-likelihood (``sigma`` on the log scale),
by central differences of its gradient. The gradient is analytic: by Fisher's
identity, d/dtheta log integral p(y | u) p(u) du = E[d/dtheta log p(y, u) | y], the
posterior expectation evaluated with the same quadrature nodes and weights
(Louis 1982; as in EM for GLMMs). Per-participant sums are bincounts, so time
and memory are linear in the number of rows and participants. Data are aggregated binomial counts (k successes of n) per
participant and design row.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize
from scipy.special import expit, gammaln, logsumexp


@dataclass
class GLMMResult:
    """Fixed effects ``beta`` with ``se``; ``sigma`` (random-intercept SD) with
    ``log_sigma_se``; ``llf`` (marginal log-likelihood incl. binomial
    coefficients); ``converged``; ``n_nodes``; ``names``."""

    names: list[str]
    beta: np.ndarray
    se: np.ndarray
    sigma: float
    log_sigma_se: float
    llf: float
    converged: bool
    n_nodes: int


def fit_logit_glmm(X: np.ndarray, k: np.ndarray, n: np.ndarray, group: np.ndarray, *, names=None,
                   n_nodes: int = 15, start=None) -> GLMMResult:
    """Fit the random-intercept logistic GLMM to aggregated counts.

    Parameters
    ----------
    X: (M, F) design matrix of the aggregated rows.
    k, n: (M,) successes and trials per row.
    group: (M,) integer participant index 0..P-1 of each row.
    """
    X = np.asarray(X, float)
    k = np.asarray(k, float)
    n = np.asarray(n, float)
    g = np.asarray(group, int)
    M, F = X.shape
    P = int(g.max()) + 1
    xq, wq = np.polynomial.hermite.hermgauss(n_nodes)
    const = float(np.sum(gammaln(n + 1) - gammaln(k + 1) - gammaln(n - k + 1)))

    def per_participant(v):
        """Sum of the rows of ``v`` (M,) or (M, Q) per participant: O(M) (no P x M incidence matrix)."""
        if v.ndim == 1:
            return np.bincount(g, weights=v, minlength=P)
        out = np.empty((P, v.shape[1]))
        for q in range(v.shape[1]):
            out[:, q] = np.bincount(g, weights=v[:, q], minlength=P)
        return out

    u_prev = np.zeros(P)  # conditional modes of the previous evaluation: a warm start for Newton

    def negll(theta):
        beta, s = theta[:F], np.exp(theta[F])
        eta = X @ beta
        u = u_prev.copy()
        for _ in range(50):  # Newton for each participant's conditional mode (vectorised)
            p = expit(eta + u[g])
            grad = per_participant(k - n * p) - u / s**2
            hess = -per_participant(n * p * (1 - p)) - 1 / s**2
            step = grad / hess
            u -= step
            if np.max(np.abs(step)) < 1e-10:
                break
        if np.all(np.isfinite(u)):
            u_prev[:] = u
        p = expit(eta + u[g])
        sd = 1 / np.sqrt(per_participant(n * p * (1 - p)) + 1 / s**2)
        U = u[:, None] + np.sqrt(2) * sd[:, None] * xq[None, :]  # (P, Q)
        E = eta[:, None] + U[g]  # (M, Q)
        ll_rows = k[:, None] * E - n[:, None] * np.logaddexp(0, E)
        lp = per_participant(ll_rows)  # (P, Q)
        log_prior = -0.5 * (U / s) ** 2 - np.log(s) - 0.5 * np.log(2 * np.pi)
        terms = lp + log_prior + xq[None, :] ** 2 + np.log(wq)[None, :]  # (P, Q)
        Lse = logsumexp(terms, axis=1)
        L = Lse + np.log(np.sqrt(2) * sd)
        # gradient by Fisher's identity: d/dtheta log int p(y|u) p(u) du = E[d/dtheta log p(y, u) | y],
        # the posterior expectation taken with the same quadrature (weights pi, each row sums to 1)
        pi = np.exp(terms - Lse[:, None])
        resid = k[:, None] - n[:, None] * expit(E)  # (M, Q): d ll_row / d eta
        g_beta = X.T @ np.sum(pi[g] * resid, axis=1)
        g_logs = float(np.sum(pi * ((U / s) ** 2 - 1.0)))
        return -(L.sum() + const), -np.r_[g_beta, g_logs]

    def f_only(theta):
        return negll(theta)[0]

    def hessian(theta):
        """Central differences of the analytic gradient, symmetrised (2 (F + 1) evaluations)."""
        d = len(theta)
        H = np.empty((d, d))
        for i in range(d):
            h = 1e-4 * max(1.0, abs(theta[i]))
            tp, tm = theta.copy(), theta.copy()
            tp[i] += h
            tm[i] -= h
            H[i] = (negll(tp)[1] - negll(tm)[1]) / (2 * h)
        return 0.5 * (H + H.T)

    if start is None:
        p0 = np.clip((k.sum() + 0.5) / (n.sum() + 1), 1e-3, 1 - 1e-3)
        start = np.r_[np.zeros(F), np.log(0.5)]
        start[0] = np.log(p0 / (1 - p0)) if np.allclose(X[:, 0], 1) else 0.0
    bounds = [(None, None)] * F + [(np.log(1e-4), np.log(20.0))]
    from threadpoolctl import threadpool_limits

    # many tiny BLAS calls: threads only add synchronisation (much slower on a loaded machine)
    with threadpool_limits(limits=1, user_api="blas"):
        res = minimize(negll, np.asarray(start, float), jac=True, method="L-BFGS-B", bounds=bounds,
                       options=dict(maxiter=2000, ftol=1e-13, gtol=1e-6))
        H = hessian(res.x)
    try:
        cov = np.linalg.inv(H)
        se = np.sqrt(np.where(np.diag(cov) > 0, np.diag(cov), np.nan))
    except np.linalg.LinAlgError:  # pragma: no cover
        se = np.full(F + 1, np.nan)
    return GLMMResult(names=list(names) if names is not None else [f"x{i}" for i in range(F)], beta=res.x[:F],
                      se=se[:F], sigma=float(np.exp(res.x[F])), log_sigma_se=float(se[F]), llf=-float(res.fun),
                      converged=bool(res.success), n_nodes=n_nodes)


@dataclass
class FirthResult:
    """Firth's bias-reduced logistic regression: ``beta``, ``se`` (from the inverse Fisher
    information at the solution), penalised log-likelihood ``pllf``, ``converged``, ``names``,
    ``max_score`` (largest |modified score| at the solution: 0 up to the tolerance)."""

    names: list[str]
    beta: np.ndarray
    se: np.ndarray
    pllf: float
    converged: bool
    n_iter: int
    max_score: float


def fit_firth_logit(X: np.ndarray, k: np.ndarray, n: np.ndarray, *, names=None, tol: float = 1e-10,
                    max_iter: int = 200) -> FirthResult:
    """Bias-reduced (Firth 1993) logistic regression on binomial counts: finite under separation.

    Maximises the penalised log-likelihood l*(beta) = l(beta) + 1/2 log det I(beta) (Jeffreys
    prior; Firth 1993, Biometrika 80:27-38, eq. 2 and its logistic case, section 3.3; Heinze &
    Schemper 2002). I = X' W X with W = diag(n p (1 - p)). The modified score is

        U*_j = sum_r x_rj (k_r - n_r p_r + h_r (1/2 - p_r)),

    h_r the diagonal of the hat matrix W^1/2 X I^-1 X' W^1/2 (Firth 1993, eq. for canonical
    links; Heinze & Schemper 2002 eq. 2), solved by Fisher scoring beta += I^-1 U* with step
    halving on l*. ``k``/``n``: successes/trials per row of ``X``. The estimate stays finite
    when a predictor separates the outcomes (ML diverges); SEs from I^-1 at the solution.
    """
    X = np.asarray(X, float)
    k = np.asarray(k, float)
    n = np.asarray(n, float)
    M, F = X.shape
    beta = np.zeros(F)

    def parts(b):
        eta = X @ b
        p = expit(eta)
        w = n * p * (1 - p)
        info = X.T @ (w[:, None] * X)
        sign, logdet = np.linalg.slogdet(info)
        ll = float(np.sum(k * eta - n * np.logaddexp(0, eta)))
        return p, w, info, ll + 0.5 * logdet if sign > 0 else -np.inf

    p, w, info, pl = parts(beta)
    converged = False
    it = 0
    score = np.full(F, np.inf)
    for it in range(1, max_iter + 1):
        inv = np.linalg.inv(info)
        h = w * np.einsum("ij,jk,ik->i", X, inv, X)
        score = X.T @ (k - n * p + h * (0.5 - p))
        step = inv @ score
        if np.max(np.abs(score)) < tol:
            converged = True
            break
        t = 1.0
        while True:
            nb = beta + t * step
            p2, w2, info2, pl2 = parts(nb)
            if pl2 >= pl - 1e-12 or t < 1e-8:
                break
            t /= 2
        beta, p, w, info, pl = nb, p2, w2, info2, pl2
    cov = np.linalg.inv(info)
    const = float(np.sum(gammaln(n + 1) - gammaln(k + 1) - gammaln(n - k + 1)))
    return FirthResult(names=list(names) if names is not None else [f"x{i}" for i in range(F)], beta=beta,
                       se=np.sqrt(np.diag(cov)), pllf=pl + const, converged=converged, n_iter=it,
                       max_score=float(np.max(np.abs(score))))


def separated_columns(X: np.ndarray, k: np.ndarray, n: np.ndarray) -> list[int]:
    """Columns of a treatment-coded design (intercept + 0/1 dummies of one factor) whose cell is separated.

    With an intercept and dummies of one categorical factor, the logistic ML estimate (with
    or without a random intercept) is finite exactly when every level's pooled counts have
    0 < k < n: a level whose answers are all one category has a fitted probability of 0 or
    1 and its coefficient diverges (complete separation; Albert & Anderson 1984). Returns
    the indices of such columns (0 = the reference level).
    """
    X = np.asarray(X, float)
    k = np.asarray(k, float)
    n = np.asarray(n, float)
    level = np.where(X[:, 1:].any(axis=1), np.argmax(X[:, 1:], axis=1) + 1, 0)
    K = np.bincount(level, weights=k, minlength=X.shape[1])
    N = np.bincount(level, weights=n, minlength=X.shape[1])
    return [int(j) for j in np.flatnonzero((N > 0) & ((K == 0) | (K == N)))]
