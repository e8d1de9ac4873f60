"""Dense solves of the tick's small systems (M(q) of 7 joints, Λ of 3 or 6 task axes):
numpy's LAPACK on the numpy path; on the compiled path Gaussian elimination with partial
pivoting in plain loops (`core.kernels.compiled_by`). Inside a running simulation a call
into LAPACK through numba costs far more than the arithmetic of a 7x7 solve: the caches
are cold after the plant's step, and LAPACK's blocked routines and numba's wrapper around
them (copies to Fortran order, checks) are a long path to bring back into them
(docs/performance.md, "Small products and solves in loops")."""

from __future__ import annotations

import numpy as np

from hlcmp_drake.core.kernels import compiled_by, jitable

SINGULAR = "Matrix is singular to machine precision."
SIZES = "incompatible array sizes"  # numba raises only constant messages


@jitable
def _eliminate(matrix: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """X with A X = B, B's columns at once: Gaussian elimination with partial pivoting and
    back substitution, in loops (the compiled path of `solve` and `inverse`).

    Parameters
    ----------
    matrix : (n, n) array
        A.
    rhs : (n, k) array
        B.

    Returns
    -------
    (n, k) array

    Raises
    ------
    numpy.linalg.LinAlgError
        If a pivot is exactly zero (A singular), as numpy's solve raises.
    ValueError
        If A is not square with as many rows as B, as numpy's solve raises.
    """
    n, k = rhs.shape
    if matrix.shape[0] != n or matrix.shape[1] != n:
        raise ValueError(SIZES + " (solve: A must be square, with as many rows as b)")
    a = np.empty((n, n))
    x = np.empty((n, k))
    for i in range(n):
        for j in range(n):
            a[i, j] = matrix[i, j]
        for c in range(k):
            x[i, c] = rhs[i, c]
    for col in range(n):
        pivot, largest = col, abs(a[col, col])
        for i in range(col + 1, n):
            if abs(a[i, col]) > largest:
                pivot, largest = i, abs(a[i, col])
        if largest == 0.0:
            raise np.linalg.LinAlgError(SINGULAR)
        if pivot != col:
            for j in range(n):
                a[col, j], a[pivot, j] = a[pivot, j], a[col, j]
            for c in range(k):
                x[col, c], x[pivot, c] = x[pivot, c], x[col, c]
        for i in range(col + 1, n):
            factor = a[i, col] / a[col, col]
            for j in range(col + 1, n):
                a[i, j] -= factor * a[col, j]
            for c in range(k):
                x[i, c] -= factor * x[col, c]
    for i in range(n - 1, -1, -1):
        for c in range(k):
            total = x[i, c]
            for j in range(i + 1, n):
                total -= a[i, j] * x[j, c]
            x[i, c] = total / a[i, i]
    return x


def _solve_vector(matrix: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """`_eliminate` for one right-hand side given as a vector."""
    column = np.empty((rhs.shape[0], 1))
    for i in range(rhs.shape[0]):
        column[i, 0] = rhs[i]
    return _eliminate(matrix, column)[:, 0].copy()


def _inverse(matrix: np.ndarray) -> np.ndarray:
    """`_eliminate` against the identity."""
    return _eliminate(matrix, np.eye(matrix.shape[0]))


# numba's typing functions: the same parameters, annotations included, as the functions
# they type and the loops they return.
def _solve_by_dimension(matrix: np.ndarray, rhs: np.ndarray):
    """numba's typing of `solve`: the loops for a vector or for a matrix of right-hand sides."""
    return _solve_vector if rhs.ndim == 1 else _eliminate


def _inverse_typing(matrix: np.ndarray):
    """numba's typing of `inverse`."""
    return _inverse


@compiled_by(_solve_by_dimension)
def solve(matrix: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """x with A x = b (b a vector, or a matrix of right-hand sides).

    Parameters
    ----------
    matrix : (n, n) array
        A, nonsingular.
    rhs : (n,) or (n, k) array
        b.

    Returns
    -------
    (n,) or (n, k) array

    Raises
    ------
    numpy.linalg.LinAlgError
        If A is singular.
    ValueError
        If the sizes do not fit.
    """
    return np.linalg.solve(matrix, rhs)


@compiled_by(_inverse_typing)
def inverse(matrix: np.ndarray) -> np.ndarray:
    """A^-1.

    Parameters
    ----------
    matrix : (n, n) array
        A, nonsingular.

    Returns
    -------
    (n, n) array

    Raises
    ------
    numpy.linalg.LinAlgError
        If A is singular.
    """
    return np.linalg.inv(matrix)


def _matrix_matrix(left: np.ndarray, right: np.ndarray) -> np.ndarray:
    """The product of two matrices, in loops."""
    rows, inner = left.shape
    if right.shape[0] != inner:
        raise ValueError(SIZES + " (matmul: the left's columns are not the right's rows)")
    out = np.zeros((rows, right.shape[1]))
    for i in range(rows):
        for k in range(inner):
            factor = left[i, k]
            for j in range(right.shape[1]):
                out[i, j] += factor * right[k, j]
    return out


def _matrix_vector(left: np.ndarray, right: np.ndarray) -> np.ndarray:
    """A matrix times a vector, in loops."""
    rows, inner = left.shape
    if right.shape[0] != inner:
        raise ValueError(SIZES + " (matmul: the matrix's columns are not the vector's length)")
    out = np.empty(rows)
    for i in range(rows):
        total = 0.0
        for k in range(inner):
            total += left[i, k] * right[k]
        out[i] = total
    return out


def _matmul_by_dimension(left: np.ndarray, right: np.ndarray):
    """numba's typing of `matmul`: a matrix times a matrix or a vector."""
    if left.ndim == 2 and right.ndim == 2:
        return _matrix_matrix
    if left.ndim == 2 and right.ndim == 1:
        return _matrix_vector
    return None


@compiled_by(_matmul_by_dimension)
def matmul(left: np.ndarray, right: np.ndarray) -> np.ndarray:
    """left @ right, for a matrix times a matrix or a vector.

    Parameters
    ----------
    left : (n, k) array
    right : (k, m) or (k,) array

    Returns
    -------
    (n, m) or (n,) array

    Raises
    ------
    ValueError
        If left's columns are not right's rows.
    """
    return left @ right
