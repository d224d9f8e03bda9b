"""Dense views of the NLP's sparse derivatives and central differences, for the NLP tests."""

from __future__ import annotations

import numpy as np

#: Central-difference step.
STEP = 1e-6


def dense_jacobian(nlp, z):
    rows, cols = nlp.jacobianstructure()
    J = np.zeros((nlp.m, nlp.n))
    np.add.at(J, (rows, cols), nlp.jacobian(z))
    return J


def dense_hessian(nlp, z, lam, obj_factor):
    rows, cols = nlp.hessianstructure()
    H = np.zeros((nlp.n, nlp.n))
    np.add.at(H, (rows, cols), nlp.hessian(z, lam, obj_factor))
    return H + np.tril(H, -1).T


def central_difference(f, z, step=STEP):
    cols = []
    for i in range(z.size):
        e = np.zeros_like(z)
        e[i] = step
        cols.append((np.asarray(f(z + e)) - np.asarray(f(z - e))) / (2 * step))
    return np.array(cols).T
