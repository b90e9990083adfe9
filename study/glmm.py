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
from the numerical Hessian of the marginal log-likelihood (``sigma`` on the
log scale). Data are aggregated binomial counts (k successes of n) per
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
    A = np.zeros((P, M))
    A[g, np.arange(M)] = 1.0  # participant-by-row incidence
    xq, wq = np.polynomial.hermite.hermgauss(n_nodes)
    const = float(np.sum(gammaln(n + 1) - gammaln(k + 1) - gammaln(n - k + 1)))

    def negll(theta):
        beta, s = theta[:F], np.exp(theta[F])
        eta = X @ beta
        u = np.zeros(P)
        for _ in range(30):  # Newton for each participant's conditional mode (vectorised)
            p = expit(eta + u[g])
            grad = A @ (k - n * p) - u / s**2
            hess = -(A @ (n * p * (1 - p))) - 1 / s**2
            step = grad / hess
            u -= step
            if np.max(np.abs(step)) < 1e-10:
                break
        p = expit(eta + u[g])
        sd = 1 / np.sqrt(A @ (n * p * (1 - p)) + 1 / s**2)
        U = u[:, None] + np.sqrt(2) * sd[:, None] * xq[None, :]  # (P, Q)
        E = eta[:, None] + U[g]  # (M, Q)
        ll_rows = k[:, None] * E - n[:, None] * np.logaddexp(0, E)
        lp = A @ ll_rows  # (P, Q)
        log_prior = -0.5 * (U / s) ** 2 - np.log(s) - 0.5 * np.log(2 * np.pi)
        L = logsumexp(lp + log_prior + xq[None, :] ** 2 + np.log(wq)[None, :], axis=1) + np.log(np.sqrt(2) * sd)
        return -(L.sum() + const)

    if start is None:
        p0 = np.clip((k.sum() + 0.5) / (n.sum() + 1), 1e-3, 1 - 1e-3)
        start = np.r_[np.zeros(F), np.log(0.5)]
        start[0] = np.log(p0 / (1 - p0)) if np.allclose(X[:, 0], 1) else 0.0
    bounds = [(None, None)] * F + [(np.log(1e-4), np.log(20.0))]
    from statsmodels.tools.numdiff import approx_hess2
    from threadpoolctl import threadpool_limits

    # many tiny BLAS calls: threads only add synchronisation (much slower on a loaded machine)
    with threadpool_limits(limits=1, user_api="blas"):
        res = minimize(negll, np.asarray(start, float), method="L-BFGS-B", bounds=bounds,
                       options=dict(maxiter=2000, ftol=1e-12, gtol=1e-7))
        H = approx_hess2(res.x, negll)
    try:
        cov = np.linalg.inv(H)
        se = np.sqrt(np.where(np.diag(cov) > 0, np.diag(cov), np.nan))
    except np.linalg.LinAlgError:  # pragma: no cover
        se = np.full(F + 1, np.nan)
    return GLMMResult(names=list(names) if names is not None else [f"x{i}" for i in range(F)], beta=res.x[:F],
                      se=se[:F], sigma=float(np.exp(res.x[F])), log_sigma_se=float(se[F]), llf=-float(res.fun),
                      converged=bool(res.success), n_nodes=n_nodes)
