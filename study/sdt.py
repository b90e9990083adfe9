"""Signal-detection sensitivity (d') for a yes/no "is this motion correct?" task.

Convention of this study (and of the flips paper, section 7 / Table 2):
the *signal* is a perturbed motion; a *hit* is answering "incorrect" to a
perturbed motion; a *false alarm* is answering "incorrect" to an unperturbed
one. So with H = P("incorrect" | perturbed) and F = P("incorrect" | unperturbed)

    d' = z(H) - z(F) = z(r0) - z(r)

where r = 1 - H and r0 = 1 - F are the rates rated *correct* (the paper's
"mean ratings") and z is the inverse standard-normal CDF. d' <= 0 means
the perturbed motions were not told apart from the correct ones (or were
judged *more* correct).

Rates of exactly 0 or 1 make z infinite. Two standard corrections:

* ``"loglinear"`` (Hautus 1995): add 0.5 to the hit and false-alarm counts
  and 1 to both trial counts, in every cell (it slightly shrinks all d'
  towards 0, less biased than 1/(2N));
* ``"1/(2N)"`` (Macmillan & Kaplan 1985): only a rate of 0 becomes 1/(2N)
  and a rate of 1 becomes 1 - 1/(2N);
* ``"none"``: no correction; an extreme rate gives +-inf.

The *ceiling* is the largest d' a correction allows for the given trial
counts (every perturbed motion called incorrect, no control called
incorrect); a d' at the ceiling means "at least this sensitive".
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.stats import norm

CORRECTIONS = ("loglinear", "1/(2N)", "none")


def _check(correction: str) -> str:
    if correction not in CORRECTIONS:
        raise ValueError(f"correction must be one of {CORRECTIONS}, got {correction!r}")
    return correction


def adjusted_rate(k, n, correction: str = "loglinear"):
    """Rate k/n after a correction for 0 and 1 (arrays broadcast)."""
    _check(correction)
    k = np.asarray(k, float)
    n = np.asarray(n, float)
    if np.any(n <= 0):
        raise ValueError("every trial count must be > 0")
    if np.any((k < 0) | (k > n)):
        raise ValueError("counts must satisfy 0 <= k <= n")
    if correction == "loglinear":
        return (k + 0.5) / (n + 1.0)
    p = k / n
    if correction == "1/(2N)":
        p = np.where(k == 0, 0.5 / n, np.where(k == n, 1.0 - 0.5 / n, p))
    return p


@dataclass(frozen=True)
class DPrime:
    """d' and its ingredients (arrays of one shape, or scalars).

    ``hit_rate``/``fa_rate`` are the raw rates; ``hit_used``/``fa_used``
    the corrected ones that d' was computed from; ``ceiling`` the largest d'
    attainable with these trial counts under the correction; ``at_ceiling``
    flags d' values within 1e-9 of it.
    """

    dprime: np.ndarray
    hit_rate: np.ndarray
    fa_rate: np.ndarray
    hit_used: np.ndarray
    fa_used: np.ndarray
    n_signal: np.ndarray
    n_noise: np.ndarray
    correction: str
    ceiling: np.ndarray

    @property
    def at_ceiling(self) -> np.ndarray:
        return np.abs(self.dprime - self.ceiling) < 1e-9


def dprime_counts(hits, n_signal, false_alarms, n_noise, correction: str = "loglinear") -> DPrime:
    """d' = z(H) - z(F) from counts: ``hits`` "incorrect" answers out of ``n_signal``
    perturbed presentations, ``false_alarms`` out of ``n_noise`` unperturbed ones."""
    _check(correction)
    h = adjusted_rate(hits, n_signal, correction)
    f = adjusted_rate(false_alarms, n_noise, correction)
    with np.errstate(divide="ignore"):
        d = norm.ppf(h) - norm.ppf(f)
    return DPrime(dprime=d, hit_rate=np.asarray(hits, float) / np.asarray(n_signal, float),
                  fa_rate=np.asarray(false_alarms, float) / np.asarray(n_noise, float), hit_used=h, fa_used=f,
                  n_signal=np.asarray(n_signal), n_noise=np.asarray(n_noise), correction=correction,
                  ceiling=dprime_ceiling(n_signal, n_noise, correction))


def dprime_ceiling(n_signal, n_noise, correction: str = "loglinear"):
    """Largest attainable d' (all perturbed called incorrect, no control called incorrect)."""
    _check(correction)
    ns = np.asarray(n_signal, float)
    nn = np.asarray(n_noise, float)
    if correction == "none":
        return np.full(np.broadcast(ns, nn).shape, np.inf)[()]
    return norm.ppf(adjusted_rate(ns, ns, correction)) - norm.ppf(adjusted_rate(np.zeros_like(nn), nn, correction))


def dprime_from_ratings(control_rating, rating, percent: bool = True):
    """The paper's d' from mean ratings (rated-correct rates): z(r0) - z(r).

    Flips paper section 7, Table 2: with ``control_rating`` the group's 0 %
    rating (72 % for angular momentum, 63 % for take-off).
    """
    s = 100.0 if percent else 1.0
    r0 = np.asarray(control_rating, float) / s
    r = np.asarray(rating, float) / s
    if np.any((r0 <= 0) | (r0 >= 1) | (r <= 0) | (r >= 1)):
        raise ValueError("ratings must lie strictly between 0 and 100 % (use counts and a correction otherwise)")
    return norm.ppf(r0) - norm.ppf(r)


def wilson_interval(k, n, level: float = 0.95):
    """Wilson score interval of a binomial proportion k/n (arrays)."""
    k = np.asarray(k, float)
    n = np.asarray(n, float)
    z = norm.ppf(0.5 + level / 2)
    p = k / n
    den = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / den
    half = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    # exact at the ends (k = 0: lower bound 0; k = n: upper bound 1), not 1e-16 off by rounding
    lo = np.where(k == 0, 0.0, centre - half)
    hi = np.where(k == n, 1.0, centre + half)
    return lo[()], hi[()]
