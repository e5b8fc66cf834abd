"""Cluster-robust (sandwich) covariance of least-squares parameters: readings of one cluster (a visit of
the slide, a thermal state) may share an error, so their scores are summed before they are squared.

    cov = B^-1 (G / (G - 1)) (n - 1) / (n - k) sum_g (J_g^T r_g)(J_g^T r_g)^T B^-1,   B = J^T J

(Liang & Zeger 1986; the small-sample factor is Stata's CR1, Cameron & Miller 2015, "A Practitioner's
Guide to Cluster-Robust Inference", J. Human Resources 50, 317, sect. IIIB). B is inverted on the
directions the data constrain, as ``fitting``'s covariance is; unconstrained parameters get infinity.
"""

from __future__ import annotations

import numpy as np

#: Eigenvalues of the column-normalised normal matrix below this share of the largest are unconstrained.
_RANK_TOLERANCE = 1e-14


def cluster_robust_covariance(jacobian: np.ndarray, residuals: np.ndarray, labels: np.ndarray) -> np.ndarray:
    """The sandwich covariance (module docstring) of parameters with Jacobian ``jacobian`` (n x k, of the
    residuals), residuals ``residuals`` (n) and cluster ``labels`` (n)."""
    jac = np.asarray(jacobian, float)
    r = np.asarray(residuals, float)
    n, k = jac.shape
    if len(r) != n or len(labels) != n:
        raise ValueError(f"cluster-robust covariance: {n} Jacobian rows, {len(r)} residuals, {len(labels)} labels")
    if k == 0:
        return np.zeros((0, 0))
    _, cluster = np.unique(labels, return_inverse=True)
    groups = int(cluster.max()) + 1 if n else 0
    if groups < 2 or n <= k:
        return np.full((k, k), np.inf)
    norms = np.sqrt(np.einsum("ij,ij->j", jac, jac))
    dead = ~(norms > 0)
    norms = np.where(dead, 1.0, norms)
    unit = jac / norms
    eigenvalues, vectors = np.linalg.eigh(unit.T @ unit)
    top = eigenvalues.max(initial=0.0)
    tiny = eigenvalues <= top * _RANK_TOLERANCE if top > 0 else np.ones_like(eigenvalues, bool)
    kept = vectors[:, ~tiny]
    bread = (kept / eigenvalues[~tiny]) @ kept.T
    scores = np.zeros((groups, k))
    np.add.at(scores, cluster.ravel(), unit * r[:, None])
    meat = scores.T @ scores * (groups / (groups - 1)) * ((n - 1) / (n - k))
    cov = bread @ meat @ bread / np.outer(norms, norms)
    unconstrained = dead | (np.abs(vectors[:, tiny]) > 0.01).any(axis=1)
    cov[unconstrained, :] = np.inf
    cov[:, unconstrained] = np.inf
    return cov
