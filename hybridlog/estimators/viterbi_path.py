"""The Viterbi path over the IMM's Markov chain and its per-mode likelihoods.

:func:`viterbi` (Rabiner 1989; :mod:`hybridlog.estimators.smoothing`'s docstring), plain
Python that numba compiles on first use.
"""

from __future__ import annotations

import math

import numpy as np

from hybridlog.estimators.kernels import argmax
from hybridlog.signals import FloatArray, IntArray


def viterbi(
    log_transitions: FloatArray, log_prior: FloatArray, log_likelihoods: FloatArray
) -> IntArray:
    """Most likely mode path: argmax over paths of ``log μ_{q0}(0) + Σ (log Π + ℓ)``.

    ``log_likelihoods[k, j]`` is ``ℓ_j(k)`` (row 0 unused: the prior stands for it).  Ties go
    to the lowest mode index.  A sample where no mode has a finite likelihood counts every
    mode alike (its row is taken as 0).  Plain Python that numba compiles on first use.
    """
    n_samples, n_q = log_likelihoods.shape
    path = np.zeros(n_samples, dtype=np.int64)
    if n_samples == 0:
        return path
    back = np.zeros((n_samples, n_q), dtype=np.int64)
    delta = log_prior.copy()
    new = np.empty(n_q)
    for k in range(1, n_samples):
        finite = False
        for j in range(n_q):
            if log_likelihoods[k, j] > -math.inf:
                finite = True
        top = -math.inf
        for j in range(n_q):
            best = 0
            best_value = -math.inf
            for i in range(n_q):
                value = delta[i] + log_transitions[i, j]
                if value > best_value:
                    best_value = value
                    best = i
            back[k, j] = best
            new[j] = best_value + (log_likelihoods[k, j] if finite else 0.0)
            if new[j] > top:
                top = new[j]
        if top == -math.inf:  # no path reaches sample k: restart from its likelihoods
            for j in range(n_q):
                delta[j] = log_likelihoods[k, j] if finite else 0.0
        else:
            for j in range(n_q):
                delta[j] = new[j] - top
    path[n_samples - 1] = argmax(delta)
    for k in range(n_samples - 1, 0, -1):
        path[k - 1] = back[k, path[k]]
    return path
