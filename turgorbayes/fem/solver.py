"""Sparse direct solves that reuse the symbolic analysis, and Newton's method for shell models.

:class:`ShellProblem` holds a mesh, its reference data and the sparsity patterns of its
constraint sets; :meth:`ShellProblem.newton` finds the equilibrium at a fixed load (pressure,
contact bodies, nodal forces) from a starting displacement.
"""

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from turgorbayes.fem.assembly import Discretization, ReducedPattern, internal_force_and_tangent
from turgorbayes.fem.loads import Surface, node_areas, pressure_load

__all__ = ["LinearSolver", "NewtonFailure", "ShellProblem", "available_solvers"]


try:  # load MKL at import, before any threadpool limit is entered (see LinearSolver.solve)
    import pypardiso
except ImportError:  # pragma: no cover - depends on the platform
    pypardiso = None


_MKL = []  # the mkl_rt handle, found once


def _mkl_threads():
    if pypardiso is None:
        return 0
    if not _MKL:
        _MKL.append(pypardiso.PyPardisoSolver().libmkl)
    return _MKL[0].mkl_get_max_threads()


def available_solvers():
    """Names accepted by :class:`LinearSolver` on this machine (``"auto"`` always)."""
    names = ["auto", "splu"]
    if pypardiso is not None:
        names[1:1] = ["pardiso", "pardiso_sym"]
    return names


class _SymmetricPart:
    """Index maps of a structurally symmetric CSR pattern: the mirror of every entry, and the
    upper triangle of ``(A + A^T)/2`` in CSR (what PARDISO's symmetric solvers read)."""

    def __init__(self, A):
        n = A.shape[0]
        rows = np.repeat(np.arange(n, dtype=np.int64), np.diff(A.indptr))
        cols = A.indices.astype(np.int64)
        key = rows * n + cols  # sorted: CSR rows in order, sorted column indices
        tkey = cols * n + rows
        mirror = np.searchsorted(key, tkey)
        if np.any(mirror >= key.size) or np.any(key[np.minimum(mirror, key.size - 1)] != tkey):
            raise RuntimeError("sparsity pattern is not structurally symmetric")
        self.mirror = mirror
        self.upper = np.flatnonzero(cols >= rows)
        self.indptr = np.concatenate(
            [[0], np.cumsum(np.bincount(rows[self.upper], minlength=n))]).astype(np.int32)
        self.indices = cols[self.upper].astype(np.int32)
        self.shape = A.shape

    def asymmetry(self, A):
        """``||A - A^T||_F / (2 ||A||_F)``."""
        return np.linalg.norm(A.data - A.data[self.mirror]) / (2.0 * np.linalg.norm(A.data))

    def upper_part(self, A):
        data = 0.5 * (A.data[self.upper] + A.data[self.mirror[self.upper]])
        return sp.csr_matrix((data, self.indices, self.indptr), shape=self.shape)


class LinearSolver:
    """Sparse direct solves: MKL PARDISO through pypardiso, else SuperLU.

    Kinds:

    * ``"pardiso"`` (``"auto"`` when pypardiso is installed): PARDISO's unsymmetric LU
      (mtype 11) of ``A`` (exact Newton).
    * ``"pardiso_sym"``: PARDISO's symmetric indefinite LDL^T (mtype -2) of the symmetric
      part ``(A + A^T)/2`` while ``A`` is nearly symmetric (``||A - A^T|| <= 2 max_asymmetry
      ||A||``, Frobenius), else the LU of ``A``; :attr:`exact` forces the LU, and
      :meth:`ShellProblem.newton` sets it for the rest of a solve in which a fresh symmetric
      factorization did not cut the residual fivefold. The capsule's tangents are symmetric
      up to the follower-pressure and contact-smoothing terms: 0.25 % (x = 0.07) to 0.6 %
      (x = 0.52) of the norm while indenting, 2-3 % at the first iterations of an inflation
      step. An LDL^T costs 0.62x an LU (its factor has 4.8 M instead of 8.9 M nonzeros on the
      shipped table's mesh) and reports the inertia (:attr:`negative_eigenvalues`), but the
      symmetric part is a worse Newton matrix: at x = 0.07 a point needed 145 instead of 142
      iterations and, with the switch to LU, took as long as with LU alone (41 s); at
      x = 0.52 the inflation stalled without the switch and took twice as long with it.
      Hence not the default; use it to see where the symmetric tangent loses positive
      definiteness (``studies/fem_tangent_inertia.py``).
    * ``"splu"``: SciPy's SuperLU of ``A``, where pypardiso is not available.

    With PARDISO the fill-reducing ordering and symbolic factorization are computed once per
    sparsity pattern and matrix type (phase 11) and reused by every later factorization
    (phase 22); the last factorization can be reused for further right-hand sides
    (:meth:`resolve`), which the modified Newton iterations do. After an LDL^T,
    :attr:`negative_eigenvalues` holds the inertia PARDISO reports (None otherwise).
    """

    #: Largest ||A - A^T|| / (2 ||A||) factorized as symmetric by ``"pardiso_sym"``.
    max_asymmetry = 0.01

    def __init__(self, kind="auto"):
        if kind == "auto":
            kind = "pardiso" if "pardiso" in available_solvers() else "splu"
        self.kind = kind
        self.exact = False
        self.negative_eigenvalues = None
        self._pardiso = {}  # (pattern key, mtype) -> PyPardisoSolver
        self._sym = {}  # pattern key -> _SymmetricPart
        self._last = None  # (pattern key, mtype, matrix) or (pattern key, None, LU object)

    def solve(self, A, b, pattern_key):
        """Factorize A (same pattern as earlier calls with this key) and solve A x = b."""
        if self.kind == "splu":
            lu = spla.splu(A.tocsc(), permc_spec="COLAMD")
            self._last = (pattern_key, None, lu)
            return lu.solve(b)
        mtype = 11
        if self.kind == "pardiso_sym" and not self.exact:
            if pattern_key not in self._sym:
                self._sym[pattern_key] = _SymmetricPart(A)
            part = self._sym[pattern_key]
            if part.asymmetry(A) <= self.max_asymmetry:
                A, mtype = part.upper_part(A), -2
        ps = self._pardiso.get((pattern_key, mtype))
        threads = _mkl_threads()
        if ps is None or ps.analysis_threads != threads:
            # PARDISO's analysis sizes its work arrays for the current MKL thread count; a
            # factorization with a different count (threadpool limits changed) segfaults
            if ps is not None:
                ps.free_memory(everything=True)
            ps = pypardiso.PyPardisoSolver(mtype=mtype)
            ps._check_A(A)
            ps.set_phase(11)
            ps._call_pardiso(A, np.zeros(A.shape[0]))
            ps.analysis_threads = threads
            self._pardiso[(pattern_key, mtype)] = ps
        ps.set_phase(23)
        self._last = (pattern_key, mtype, A)
        x = ps._call_pardiso(A, np.asfortranarray(b))
        self.negative_eigenvalues = int(ps.iparm[22]) if mtype == -2 else None
        return x

    def resolve(self, b, pattern_key):
        """Solve with the last factorization (None if there is none for this pattern)."""
        if self._last is None or self._last[0] != pattern_key:
            return None
        _, mtype, last = self._last
        if mtype is None:
            return last.solve(b)
        ps = self._pardiso[(pattern_key, mtype)]
        if ps.analysis_threads != _mkl_threads():
            return None
        ps.set_phase(33)
        return ps._call_pardiso(last, np.asfortranarray(b))

    def close(self):
        """Release the solver's factorizations."""
        for ps in self._pardiso.values():
            ps.free_memory(everything=True)
        self._pardiso.clear()
        self._last = None


class NewtonFailure(Exception):
    """Internal signal that one Newton solve failed (the drivers cut the step or re-raise)."""

    def __init__(self, residual, detail):
        self.residual, self.detail = residual, detail
        super().__init__(detail)


class ShellProblem:
    """A shell mesh with its material, pressure surface, contact candidates and constraints.

    Parameters
    ----------
    mesh : turgorbayes.fem.mesh.ShellMesh
    solver : str
        ``"auto"``, ``"pardiso"`` or ``"splu"``.
    """

    law = "log"  #: wall law used by the kernels (key of turgorbayes.fem.material.LAWS)

    def __init__(self, mesh, solver="auto"):
        self.mesh = mesh
        self.disc = Discretization.from_mesh(mesh)
        self.solver = LinearSolver(solver)
        self.inner_surface = Surface.from_facets(mesh, mesh.inner_facets)
        self.outer = mesh.outer_nodes
        outer_surface = Surface.from_facets(mesh, mesh.outer_facets)
        self.outer_area = node_areas(outer_surface, mesh.n_nodes)[self.outer]
        self._patterns = {}

    def pattern(self, fixed):
        """Reduced sparsity pattern (cached) for the boolean DOF mask ``fixed``."""
        key = hash(np.packbits(fixed).tobytes())
        if key not in self._patterns:
            pat = ReducedPattern(self.mesh.elements, self.mesh.n_nodes, fixed)
            pat.key = key
            pat.pressure_slots = pat.slots(self.inner_surface.nodes)
            pat.outer_slots = pat.slots(self.outer[:, None])
            self._patterns[key] = pat
        return self._patterns[key]

    def newton(self, u, D, fixed, P=0.0, bodies=(), f_ext=None, rtol=1e-8, max_iter=25,
               max_step=np.inf, stall_window=0):
        """Equilibrium displacement at a fixed load, by Newton's method from ``u``.

        Parameters
        ----------
        u : ndarray (n_nodes, 3) [m]
            Starting displacement (fixed DOFs keep their values).
        D : ndarray (6, 6) [Pa]
            Small-strain stiffness in the material axes.
        fixed : ndarray of bool (3 n_nodes,)
        P : float [Pa]
            Follower pressure on the inner surface.
        bodies : sequence of callables
            Each ``body(x_outer, area) -> (idx, f, K, gap)`` (see
            :mod:`turgorbayes.fem.contact`) acting on the outer-surface nodes.
        f_ext : ndarray (3 n_nodes,) [N], optional
            Dead nodal loads.
        rtol : float
            Relative residual (to the internal-force norm) that counts as converged.
        max_iter : int
        max_step : float [m]
            Largest nodal displacement change per iteration (larger updates are scaled down).
        stall_window : int
            If > 0, give up (``NewtonFailure``) as soon as the residual has not fallen tenfold
            over this many iterations: a stalled solve (contact nodes flipping in and out) then
            costs the caller a step cut instead of ``max_iter`` iterations.

        Returns
        -------
        u : ndarray (n_nodes, 3)
        info : dict
            ``iterations``, ``factorizations``, ``residual``, ``contact`` (per body: forces
            summed [N], active node indices, gaps), ``negative_eigenvalues`` (of the
            symmetric part of the last tangent factorized, if that was an LDL^T; else None),
            ``exact_switch`` (the ``"pardiso_sym"`` solver switched to LU in this solve).

        Raises
        ------
        NewtonFailure
        """
        exact = self.solver.exact
        try:
            return self._iterate(u, D, self.pattern(fixed), P, bodies, f_ext, rtol, max_iter,
                                 max_step, stall_window)
        finally:
            self.solver.exact = exact

    def _iterate(self, u, D, pat, P, bodies, f_ext, rtol, max_iter, max_step, stall_window):
        u = u.copy()
        n_dofs = self.mesh.n_dofs
        args = (D, pat, P, bodies, f_ext)
        r, _, contact = self.residual_and_tangent(u, *args, want_tangent=False)
        res = first = self._relative(r, pat)
        du_norm, refactor, n_factor, n_exact = np.inf, True, 0, 0
        history = [res]
        for it in range(max_iter + 1):
            if res < rtol or (du_norm < 1e-9 * self.mesh.thickness and res < 1e3 * rtol):
                return u, {"iterations": it, "factorizations": n_factor, "residual": res,
                           "contact": contact, "exact_switch": n_exact > 0,
                           "negative_eigenvalues": self.solver.negative_eigenvalues}
            if it == max_iter:
                break
            du = np.zeros(n_dofs)
            step = None if refactor else self.solver.resolve(-r[pat.free], pat.key)
            fresh_symmetric = False
            if step is None:
                _, A, _ = self.residual_and_tangent(u, *args)
                step = self.solver.solve(A, -r[pat.free], pat.key)
                n_factor += 1
                fresh_symmetric = self.solver.negative_eigenvalues is not None
            du[pat.free] = step
            if not np.all(np.isfinite(du)):
                raise NewtonFailure(res, "linear solve gave non-finite values (singular tangent?)")
            du_norm = np.max(np.abs(du))
            if du_norm > max_step:
                du *= max_step / du_norm
                du_norm = max_step
            res_old = res
            u, r, contact, res = self._line_search(u, du.reshape(-1, 3), res, args)
            if not np.isfinite(res) or res > 1e8 * max(first, rtol):
                raise NewtonFailure(res, f"diverged at iteration {it + 1}")
            # modified Newton: keep the factorization while it still contracts fast
            refactor = res > self.reuse_rate * res_old
            if refactor and fresh_symmetric:
                # the symmetric part of a fresh tangent did not contract fast: the tangent's
                # antisymmetric part matters here (inflation at high pressure), so finish this
                # solve with exact LU factorizations
                self.solver.exact, n_exact = True, n_exact + 1
            history.append(res)
            if 0 < stall_window < len(history) and res > 0.1 * history[-1 - stall_window]:
                raise NewtonFailure(res, f"stalled: residual fell less than tenfold in {stall_window} "
                                         f"iterations (iteration {it + 1}, started at {history[0]:.3g})")
        raise NewtonFailure(res, f"no convergence in {max_iter} iterations")

    #: Reuse the last factorization while each iteration cuts the residual by this factor.
    reuse_rate = 0.2

    def _relative(self, r, pat):
        return np.linalg.norm(r[pat.free]) / max(self._scale, 1e-300)

    def _line_search(self, u, du, res, args, max_halvings=3):
        """Backtrack on the residual norm: halve the step while it does not decrease."""
        alpha = 1.0
        for _ in range(max_halvings + 1):
            trial = u + alpha * du
            r, _, contact = self.residual_and_tangent(trial, *args, want_tangent=False)
            res_trial = self._relative(r, args[1])
            if np.isfinite(res_trial) and res_trial < res:
                break
            alpha *= 0.5
        if not np.isfinite(res_trial):
            raise NewtonFailure(res, "every line-search trial gave a non-finite residual "
                                     "(an element turned inside out)")
        return trial, r, contact, res_trial

    def residual_and_tangent(self, u, D, pat, P, bodies, f_ext, want_tangent=True):
        x = self.mesh.X + u
        f_el, K_el = internal_force_and_tangent(self.disc, u, D, want_tangent, self.law)
        n_dofs = self.mesh.n_dofs
        f_int = pat.scatter_vector(f_el, n_dofs)
        f_load = np.zeros(n_dofs) if f_ext is None else f_ext.copy()
        extras = []
        if P != 0.0:
            fp, dfp = pressure_load(self.inner_surface, u, P, want_tangent)
            edofs = (3 * self.inner_surface.nodes[:, :, None] + np.arange(3)).ravel()
            f_load += np.bincount(edofs, weights=fp.ravel(), minlength=n_dofs)
            if want_tangent:
                extras.append((pat.pressure_slots, -dfp))
        contact = []
        xo = x[self.outer]
        for body in bodies:
            idx, f, K, gap = body(xo, self.outer_area)
            nodes = self.outer[idx]
            np.add.at(f_load, (3 * nodes[:, None] + np.arange(3)).ravel(), f.ravel())
            extras.append((pat.outer_slots[idx], K))
            contact.append({"force": f.sum(axis=0), "nodes": nodes, "gap": gap})
        self._scale = max(np.linalg.norm(f_int[pat.free]), np.linalg.norm(f_load[pat.free]))
        A = pat.matrix(K_el, extras) if want_tangent else None
        return f_int - f_load, A, contact
