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
from scipy.special import expit, gammaln

from mocomp.core._compiled import njit


@njit
def _quadrature(eta, k, n, U, base):
    """Adaptive Gauss-Hermite sums of :func:`fit_logit_glmm` for every participant.

    ``eta``, ``k``, ``n`` (P, L): linear predictor without the random effect, successes and
    trials of each participant's (padded) rows; ``U`` (P, Q): the random-intercept nodes;
    ``base`` (P, Q): log prior + log weight + x_q^2 of each node. With E = eta + U_q,
    terms_q = sum_l [k E - n log(1 + e^E)] + base_q; returns Lse = logsumexp_q terms (P,),
    pi = exp(terms - Lse) (P, Q) and w = sum_q pi_q (k - n expit(E)) (P, L). Equal to the
    numpy expressions (logaddexp, expit) to rounding; O(P L Q) time, O(P (L + Q)) memory.
    """
    P, L = eta.shape
    Q = U.shape[1]
    Lse = np.empty(P)
    pi = np.empty((P, Q))
    w = np.zeros((P, L))
    terms = np.empty(Q)
    sig = np.empty((Q, L))  # expit(E) of the participant's rows at each node (one exp per element)
    for i in range(P):
        for q in range(Q):
            acc = 0.0
            for j in range(L):
                if n[i, j] == 0.0:
                    sig[q, j] = 0.0
                    continue
                e_ = eta[i, j] + U[i, q]
                z = np.exp(-abs(e_))
                sig[q, j] = 1.0 / (1.0 + z) if e_ >= 0 else z / (1.0 + z)
                acc += k[i, j] * e_ - n[i, j] * (max(e_, 0.0) + np.log1p(z))
            terms[q] = acc + base[i, q]
        m = terms.max()
        tot = 0.0
        for q in range(Q):
            tot += np.exp(terms[q] - m)
        lse = m + np.log(tot)
        Lse[i] = lse
        for q in range(Q):
            pq = np.exp(terms[q] - lse)
            pi[i, q] = pq
            for j in range(L):
                w[i, j] += pq * (k[i, j] - n[i, j] * sig[q, j])
    return Lse, pi, w


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
    # participant-major padded layout (P, L): row j of participant i at [i, j], padding rows have
    # k = n = 0 and x = 0, so they add exactly 0 to every sum below (k E - n log(1 + e^E) = 0,
    # k - n expit(E) = 0). Per-participant sums become sums over axis 1: no bincount loops over
    # the Q nodes and no (M, Q) gathers; memory P x L x Q.
    order = np.argsort(g, kind="stable")
    cnt = np.bincount(g, minlength=P)
    L = max(int(cnt.max()), 1)
    start_i = np.r_[0, np.cumsum(cnt)[:-1]]
    pos = np.arange(M) - np.repeat(start_i, cnt)
    Xp = np.zeros((P, L, F))
    kp = np.zeros((P, L))
    np_ = np.zeros((P, L))
    Xp[g[order], pos] = X[order]
    kp[g[order], pos] = k[order]
    np_[g[order], pos] = n[order]

    u_prev = np.zeros(P)  # conditional modes of the previous evaluation: a warm start for Newton

    def negll(theta):
        beta, s = theta[:F], np.exp(theta[F])
        eta = Xp @ beta  # (P, L)
        u = u_prev.copy()
        for _ in range(50):  # Newton for each participant's conditional mode (vectorised)
            p = expit(eta + u[:, None])
            grad = (kp - np_ * p).sum(1) - u / s**2
            hess = -(np_ * p * (1 - p)).sum(1) - 1 / s**2
            step = grad / hess
            u -= step
            if np.max(np.abs(step)) < 1e-10:
                break
        if np.all(np.isfinite(u)):
            u_prev[:] = u
        p = expit(eta + u[:, None])
        sd = 1 / np.sqrt((np_ * p * (1 - p)).sum(1) + 1 / s**2)
        U = u[:, None] + np.sqrt(2) * sd[:, None] * xq[None, :]  # (P, Q)
        log_prior = -0.5 * (U / s) ** 2 - np.log(s) - 0.5 * np.log(2 * np.pi)
        base = log_prior + xq[None, :] ** 2 + np.log(wq)[None, :]  # (P, Q)
        # per participant: terms = log p(y_i | U_iq) + base (Gauss-Hermite, adaptive), Lse their
        # logsumexp, pi the posterior weights, w_rows = sum_q pi (k - n expit(E)); compiled, no (P, L, Q) arrays
        Lse, pi, w_rows = _quadrature(eta, kp, np_, U, base)
        L_ = Lse + np.log(np.sqrt(2) * sd)
        # gradient by Fisher's identity: d/dtheta log int p(y|u) p(u) du = E[d/dtheta log p(y, u) | y],
        # the posterior expectation taken with the same quadrature (weights pi, each row sums to 1)
        g_beta = np.einsum("plf,pl->f", Xp, w_rows)
        g_logs = float(np.sum(pi * ((U / s) ** 2 - 1.0)))
        return -(L_.sum() + const), -np.r_[g_beta, g_logs]

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


@dataclass
class GEEResult:
    """Population-averaged logistic model by GEE, exchangeable working correlation.

    ``beta`` with robust (sandwich) ``se`` and ``cov`` (F, F); ``rho`` the working
    correlation; ``n_iter``; ``converged`` (score norm below ``ctol``); ``names``."""

    names: list[str]
    beta: np.ndarray
    se: np.ndarray
    cov: np.ndarray
    rho: float
    n_iter: int
    converged: bool


def fit_gee_exchangeable(X: np.ndarray, k: np.ndarray, n: np.ndarray, group: np.ndarray, *, names=None,
                         maxiter: int = 60, ctol: float = 1e-6) -> GEEResult:
    """Logistic GEE with an exchangeable working correlation, from binomial counts per cell.

    The model and algorithm are those of statsmodels' ``GEE(y, X, groups, Binomial(),
    Exchangeable()).fit()`` on the Bernoulli rows (Liang & Zeger 1986, Biometrika 73:13-22,
    eq. 6 estimating equations sum_i D_i' V_i^-1 (y_i - mu_i) = 0 with V_i = A_i^1/2 R(rho)
    A_i^1/2, robust covariance B^-1 (sum_i U_i U_i') B^-1, their section 3), but computed from
    the cells: rows ``r`` of ``X`` are covariate patterns, ``k``/``n`` the "1" answers / trials
    of participant ``group[r]`` with that pattern. Every Bernoulli row of a cell has the same
    mean mu, variance a = mu (1 - mu) and derivative a x, and with R^-1 = [I - c' 1 1'] / (1 - rho),
    c' = rho / (1 + (m_i - 1) rho) (m_i the participant's trials), each cluster's sums reduce to
    sums over its cells:

        B_i = sum_r n_r a_r x_r x_r' / (1 - rho) - c_i T_i T_i',  T_i = sum_r n_r sqrt(a_r) x_r
        U_i = sum_r x_r (k_r - n_r mu_r) / (1 - rho) - c_i T_i S_i,  S_i = sum_r (k_r - n_r mu_r) / sqrt(a_r)

        (c_i = rho / (1 - rho) / (1 + rho (m_i - 1))), and the moment estimate of rho
        (statsmodels' ``Exchangeable.update``, ddof = F) from the Pearson residuals
        sum_rows e^2 = sum_r [k_r (1 - mu_r)^2 + (n_r - k_r) mu_r^2] / a_r and
        sum_pairs e e' = sum_i (S_i^2 - sum_rows e^2) / 2.

    Same iteration as statsmodels (start at the independence GLM, one Fisher step, then rho,
    stop when |U| < ``ctol`` after at least one rho update), so the results agree with the
    row-level fit to rounding; time and memory are O(cells) instead of O(trials).
    """
    X = np.asarray(X, float)
    k = np.asarray(k, float)
    n = np.asarray(n, float)
    g = np.asarray(group, int)
    M, F = X.shape
    P = int(g.max()) + 1
    m = np.bincount(g, weights=n, minlength=P)  # trials per cluster
    N = float(m.sum())
    n_pairs = float(np.sum(0.5 * m * (m - 1)))

    def per_cluster(v):  # (M, F) -> (P, F)
        out = np.empty((P, v.shape[1]))
        for j in range(v.shape[1]):
            out[:, j] = np.bincount(g, weights=v[:, j], minlength=P)
        return out

    # start: independence GLM (the ML logistic regression of the pooled counts), by Newton
    beta = np.zeros(F)
    for _ in range(100):
        mu = expit(X @ beta)
        a = mu * (1 - mu)
        step = np.linalg.solve(X.T @ ((n * a)[:, None] * X), X.T @ (k - n * mu))
        beta = beta + step
        if np.max(np.abs(step)) < 1e-13 * max(1.0, np.max(np.abs(beta))):
            break
    rho = 0.0

    def pieces(b, rho):
        mu = expit(X @ b)
        a = mu * (1 - mu)
        sd = np.sqrt(a)
        e = k - n * mu
        c = rho / (1 - rho) / (1 + rho * (m - 1))  # (P,)
        T = per_cluster((n * sd)[:, None] * X)  # (P, F)
        S = np.bincount(g, weights=e / sd, minlength=P)  # (P,)
        Bm = X.T @ ((n * a)[:, None] * X) / (1 - rho) - (T * c[:, None]).T @ T
        Ui = per_cluster(e[:, None] * X) / (1 - rho) - c[:, None] * T * S[:, None]  # (P, F)
        return mu, a, e, S, Bm, Ui

    converged, n_iter, n_assoc = False, 0, 0
    for itr in range(maxiter):
        n_iter = itr + 1
        _, _, _, _, Bm, Ui = pieces(beta, rho)
        score = Ui.sum(0)
        try:
            update = np.linalg.solve(Bm, score)
        except np.linalg.LinAlgError:  # pragma: no cover - as statsmodels
            update = np.linalg.pinv(Bm) @ score
        beta = beta + update
        mu, a, e, S, _, _ = pieces(beta, rho)
        if np.sqrt(np.sum(score**2)) < ctol and n_assoc > 0:
            converged = True
            break
        # moment estimate of rho (statsmodels Exchangeable.update; scale 1 for the binomial GEE itself)
        ssq = (k * (1 - mu) ** 2 + (n - k) * mu**2) / a
        ssr_i = np.bincount(g, weights=ssq, minlength=P)
        scale = ssr_i.sum() / (N - F)
        rho = float(np.sum((S**2 - ssr_i) / 2) / scale / (n_pairs - F))
        n_assoc += 1
    _, _, _, _, Bm, Ui = pieces(beta, rho)
    try:
        Bi = np.linalg.inv(Bm)
    except np.linalg.LinAlgError:  # pragma: no cover
        Bi = np.linalg.pinv(Bm)
    cov = Bi @ (Ui.T @ Ui) @ Bi
    return GEEResult(names=list(names) if names is not None else [f"x{i}" for i in range(F)], beta=beta,
                     se=np.sqrt(np.diag(cov)), cov=cov, rho=rho, n_iter=n_iter, converged=converged)
