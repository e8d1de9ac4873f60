"""hlcmp_drake.core.small_linalg: the compiled path's loops give numpy's solve, inverse and
product to 1e-12 (the tick's sizes and a few others, well and badly conditioned), and a
singular matrix is refused on both paths."""

import functools

import numpy as np
import pytest

from hlcmp_drake.core.kernels import numba_available
from hlcmp_drake.core.small_linalg import inverse, matmul, solve

needs_numba = pytest.mark.skipif(not numba_available(), reason="numba is not installed")
# One worker for the module: numba compiles the caller once per argument layout, several
# seconds each time, and would do it again on every worker.
pytestmark = pytest.mark.xdist_group("compiled_small_linalg")


def _calls(matrix, vector, columns, wide):
    return (
        solve(matrix, vector),
        solve(matrix, columns),
        inverse(matrix),
        matmul(wide, columns),
        matmul(wide, vector),
    )


@functools.cache
def compiled_calls():
    """solve (vector and matrix right-hand sides), inverse and matmul (matrix and vector),
    as a compiled caller sees them: compiled once a process, its machine code kept in the
    kernels' cache folder (`kernel_cache_folder`, named by core's sources, so an edit of the
    loops compiles it anew) -- several seconds a layout otherwise, on every run."""
    import numba

    return numba.njit(cache=True)(_calls)


def mass_like(rng, n, condition):
    """A symmetric positive definite matrix with eigenvalues from 1 to `condition`."""
    q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    return (q * np.geomspace(1.0, condition, n)) @ q.T


@needs_numba
@pytest.mark.parametrize("n", [1, 3, 6, 7])
@pytest.mark.parametrize("condition", [1.0, 1e4])
def test_compiled_loops_agree_with_numpy(n, condition):
    calls, rng = compiled_calls(), np.random.default_rng(n)
    for matrix in (mass_like(rng, n, condition), rng.normal(size=(n, n)) + n * np.eye(n)):
        vector, columns = rng.normal(size=n), rng.normal(size=(3, n)).T  # a transposed view
        wide = rng.normal(size=(4, n))
        expected = (
            np.linalg.solve(matrix, vector),
            np.linalg.solve(matrix, columns),
            np.linalg.inv(matrix),
            wide @ columns,
            wide @ vector,
        )
        for got, want in zip(calls(matrix, vector, columns, wide), expected):
            scale = max(1.0, float(np.max(np.abs(want))))
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * scale)


@needs_numba
@pytest.mark.parametrize(
    "matrix, rhs, solution",
    [
        ([[0.0, 2.0], [3.0, 1.0]], [4.0, 5.0], [1.0, 2.0]),  # a zero on the diagonal
        ([[1e-20, 1.0], [1.0, 1.0]], [1.0, 2.0], [1.0, 1.0]),  # a tiny pivot: the row swapped
    ],
)
def test_the_largest_pivot_is_taken(matrix, rhs, solution):
    got = compiled_calls()(np.array(matrix), np.array(rhs), np.eye(2), np.eye(2))[0]
    np.testing.assert_allclose(got, solution, rtol=0, atol=1e-15)


@needs_numba
@pytest.mark.parametrize(
    "sizes",
    [
        ((3, 3), (2,), (3, 3), (3, 3)),  # solve: b shorter than A
        ((3, 2), (3,), (3, 1), (3, 3)),  # solve: A not square
        ((3, 3), (3,), (3, 1), (4, 2)),  # matmul: 2 columns against 3 rows
    ],
)
def test_sizes_that_do_not_fit_are_refused_by_the_loops_themselves(sizes):
    """A ValueError, as numpy gives, rather than reading past an array's end; the loops'
    own message shows that the compiled path runs them (not numba's LAPACK or BLAS)."""
    arrays = [
        np.ones(size) + np.eye(*size[:1], *size[1:]) if len(size) == 2 else np.ones(size)
        for size in sizes
    ]
    with pytest.raises(ValueError, match="incompatible array sizes \\((solve|matmul):"):
        compiled_calls()(*arrays)


@pytest.mark.parametrize("compiled", [False, pytest.param(True, marks=needs_numba)])
def test_a_singular_matrix_is_refused(compiled):
    singular = np.array([[1.0, 2.0], [2.0, 4.0]])
    with pytest.raises(np.linalg.LinAlgError):
        if compiled:
            compiled_calls()(singular, np.ones(2), np.eye(2), np.eye(2))
        else:
            inverse(singular)
