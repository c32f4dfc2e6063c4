"""Shared by the tests that read a Newton system (`ImplicitIntegrator.newton_system`)."""

import numpy as np


def dense_hessian(system):
    """The full symmetric matrix of a system's lower-triangle CSC Hessian."""
    n = system["size"]
    H = np.zeros((n, n))
    indptr, indices, data = (
        system["hessian_indptr"],
        system["hessian_indices"],
        system["hessian_data"],
    )
    for column in range(n):
        for p in range(indptr[column], indptr[column + 1]):
            H[indices[p], column] = H[column, indices[p]] = data[p]
    return H
