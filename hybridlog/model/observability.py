r"""What a linear mode's outputs do not see, from its matrices alone (numpy; no sympy).

The unobservable subspace of a mode ``x(k+1) = A x(k) + ...``, ``y = C x``: the null space of
:math:`[C; CA; \dots; CA^{n-1}]`, which ``A`` leaves invariant, and the eigenvalues of ``A``
on it (:func:`unseen_eigenvalues`).  The model's diagnosis (:mod:`hybridlog.model.diagnosis`)
warns of them; the estimators' capabilities (``chiu`` and ``kmeans``: paper 001's LMI (15)
has no gain along one of size 1 or more) refuse a model by them before any log is read, a
warm run's model having no sympy loaded.
"""

from __future__ import annotations

import numpy as np

from hybridlog.signals import FloatArray

RANK = float(np.sqrt(np.finfo(np.float64).eps))
"""Singular values below this fraction of the largest count as zero (matrices given to a few
digits are exact to far more than this in their rank)."""


def unobservable_basis(A: FloatArray, C: FloatArray) -> FloatArray:
    r"""An orthonormal basis ``(n, k)`` of the null space of :math:`[C; CA; \dots; CA^{n-1}]`.

    ``A`` is divided by its spectral norm first (when above 1): the null space is the same,
    and the powers stay in range.
    """
    n = A.shape[0]
    scaled = A / max(1.0, float(np.linalg.norm(A, 2)))
    blocks = [C]
    for _ in range(n - 1):
        blocks.append(blocks[-1] @ scaled)
    return null_space(np.vstack(blocks))


def null_space(matrix: FloatArray) -> FloatArray:
    """An orthonormal basis ``(n, k)`` of ``matrix``'s null space (rank by :data:`RANK`)."""
    _, singular, vt = np.linalg.svd(matrix)
    largest = singular[0] if singular.size else 0.0
    rank = int(np.sum(singular > RANK * largest)) if largest > 0.0 else 0
    basis: FloatArray = vt[rank:].T
    return basis


def unseen_eigenvalues(A: FloatArray, basis: FloatArray) -> list[complex]:
    """The eigenvalues of ``A`` on the invariant subspace ``basis`` spans (its unseen ones)."""
    if basis.shape[1] == 0:
        return []
    return [complex(v) for v in np.linalg.eigvals(basis.T @ A @ basis)]
