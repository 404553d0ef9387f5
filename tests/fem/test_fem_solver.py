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


def _asymmetry(A):
    return spla.norm(A - A.T) / (2 * spla.norm(A))


@pytest.mark.parametrize("asym", [0.003, 0.5])
@pytest.mark.parametrize("kind", [k for k in available_solvers() if k != "auto"])
def test_solvers_against_scipy_spsolve(rng, kind, asym):
    # Reference: SciPy's spsolve of A, or, for "pardiso_sym" on a nearly symmetric A
    # (||A - A^T|| <= 2 max_asymmetry ||A||), of its symmetric part (A + A^T)/2 (by design;
    # see its docstring); a strongly unsymmetric A it solves by LU, i.e. exactly.
    A = _structurally_symmetric(rng, asym=asym)
    nearly = _asymmetry(A) <= LinearSolver.max_asymmetry
    assert nearly == (asym < 0.01)  # the two cases really are on either side of the switch
    b = rng.normal(size=A.shape[0])

    def reference(M):
        return spla.spsolve((0.5 * (M + M.T) if kind == "pardiso_sym" and nearly else M).tocsc(), b)

    solver = LinearSolver(kind)
    assert_allclose(solver.solve(A, b, "p"), reference(A), rtol=1e-10)
    # a second factorization with the same pattern reuses the analysis; resolve reuses it
    A2 = A.copy()
    A2.data *= 1.0 + 0.1 * rng.random(A2.nnz)
    expected2 = reference(A2)
    assert_allclose(solver.solve(A2, b, "p"), expected2, rtol=1e-10)
    assert_allclose(solver.resolve(2 * b, "p"), 2 * expected2, rtol=1e-10)
    assert solver.resolve(b, "other pattern") is None
    solver.close()


def test_symmetric_kind_differs_from_lu_on_nearly_symmetric_matrix(rng):
    # The symmetric kind must really drop the antisymmetric part below the switch (else the
    # test above could pass with an LU in disguise), and report the inertia: 0 here, as the
    # matrix is diagonally dominant with a positive diagonal.
    if "pardiso_sym" not in available_solvers():
        pytest.skip("pypardiso not installed")
    A = _structurally_symmetric(rng, asym=0.003)
    b = rng.normal(size=A.shape[0])
    solver = LinearSolver("pardiso_sym")
    x_sym = solver.solve(A, b, "p")
    assert solver.negative_eigenvalues == 0
    x_lu = LinearSolver("pardiso").solve(A, b, "p")
    assert np.linalg.norm(x_sym - x_lu) > 1e-8 * np.linalg.norm(x_lu)
    solver.exact = True  # forced LU: the exact solution, no inertia
    assert_allclose(solver.solve(A, b, "p"), x_lu, rtol=1e-10)
    assert solver.negative_eigenvalues is None


def test_symmetric_kind_counts_negative_eigenvalues(rng):
    # Reference: numpy's eigenvalues of a small symmetric indefinite matrix.
    if "pardiso_sym" not in available_solvers():
        pytest.skip("pypardiso not installed")
    M = rng.normal(size=(8, 8))
    M = M + M.T
    A = sp.csr_matrix(M)
    solver = LinearSolver("pardiso_sym")
    x = solver.solve(A, np.ones(8), "p")
    assert_allclose(M @ x, np.ones(8), atol=1e-8)
    assert solver.negative_eigenvalues == np.sum(np.linalg.eigvalsh(M) < 0)


def test_symmetric_kind_rejects_unsymmetric_pattern(rng):
    if "pardiso_sym" not in available_solvers():
        pytest.skip("pypardiso not installed")
    A = sp.csr_matrix(np.triu(np.ones((5, 5))) + 4 * np.eye(5))
    with pytest.raises(RuntimeError, match="structurally symmetric"):
        LinearSolver("pardiso_sym").solve(A, np.ones(5), "p")
