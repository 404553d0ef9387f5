"""Sparse direct solvers of the FE model (turgorbayes.fem.solver.LinearSolver)."""

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numpy.testing import assert_allclose

from turgorbayes.fem.solver import LinearSolver, available_solvers


def _structurally_symmetric(rng, n=60, asym=0.05):
    """A diagonally dominant sparse matrix with a symmetric pattern and unsymmetric values."""
    pattern = sp.random(n, n, density=0.08, random_state=np.random.RandomState(3), format="csr")
    pattern = ((pattern + pattern.T) != 0).astype(float)
    S = pattern.multiply(rng.normal(size=(n, n)))
    S = S + S.T
    N = pattern.multiply(rng.normal(size=(n, n)))
    A = sp.csr_matrix(S + asym * (N - N.T)) + sp.diags(np.full(n, 2.0 * abs(S).sum(axis=1).max()))
    A.sort_indices()
    return A


@pytest.mark.parametrize("kind", [k for k in available_solvers() if k != "auto"])
def test_solvers_against_scipy_spsolve(rng, kind):
    # Reference: SciPy's spsolve of A (LU kinds) or of the symmetric part (A + A^T)/2
    # ("pardiso_sym", which solves with the symmetric part by design; see its docstring).
    A = _structurally_symmetric(rng)
    b = rng.normal(size=A.shape[0])
    M = 0.5 * (A + A.T) if kind == "pardiso_sym" else A
    expected = spla.spsolve(M.tocsc(), b)
    solver = LinearSolver(kind)
    assert_allclose(solver.solve(A, b, "p"), expected, rtol=1e-10)
    # a second factorization with the same pattern reuses the analysis; resolve reuses it
    A2 = A.copy()
    A2.data *= 1.0 + 0.1 * rng.random(A2.nnz)
    M2 = 0.5 * (A2 + A2.T) if kind == "pardiso_sym" else A2
    expected2 = spla.spsolve(M2.tocsc(), b)
    assert_allclose(solver.solve(A2, b, "p"), expected2, rtol=1e-10)
    assert_allclose(solver.resolve(2 * b, "p"), 2 * expected2, rtol=1e-10)
    assert solver.resolve(b, "other pattern") is None
    solver.close()


def test_symmetric_kind_differs_from_lu_on_unsymmetric_matrix(rng):
    # The symmetric kind must really drop the antisymmetric part (else the test above could
    # pass with an LU in disguise): with a 50 % antisymmetric part the two solutions differ.
    if "pardiso_sym" not in available_solvers():
        pytest.skip("pypardiso not installed")
    A = _structurally_symmetric(rng, asym=0.5)
    b = rng.normal(size=A.shape[0])
    x_sym = LinearSolver("pardiso_sym").solve(A, b, "p")
    x_lu = LinearSolver("pardiso").solve(A, b, "p")
    assert np.linalg.norm(x_sym - x_lu) > 1e-6 * np.linalg.norm(x_lu)


def test_symmetric_kind_rejects_unsymmetric_pattern(rng):
    if "pardiso_sym" not in available_solvers():
        pytest.skip("pypardiso not installed")
    A = sp.csr_matrix(np.triu(np.ones((5, 5))) + 4 * np.eye(5))
    with pytest.raises(RuntimeError, match="structurally symmetric"):
        LinearSolver("pardiso_sym").solve(A, np.ones(5), "p")
