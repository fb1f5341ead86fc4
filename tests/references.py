"""Independent reference solvers shared by the tests (tests only; none goes through the code it checks):

* :func:`direct_mixed_solve`: a dense LU of the mixed system (26) with the contact held closed on a given active
  set (tests/test_solve.py, tests/test_info_and_default.py, tests/test_sparse_route.py,
  tests/test_adversarial.py);
* :func:`dense_kkt` and :func:`enumerated`: a dense mixed-system callable for one body with contact rows, and the
  minimiser found by trying every active set (tests/test_finish3d.py, tests/test_mixed_cuts_factored.py);
* :func:`dense_newton`: the Signorini problem of one body with a nonlinear bulk energy by dense active-set and
  Newton steps (tests/test_bulk_energy.py, tests/test_hencky_fast.py);
* :func:`true_slack`, :func:`slack_maximum` and :func:`check_argmax`: the true slack q_h - delta of a P2 element
  against a curved rigid obstacle from its definition, its maximum by dense sampling and zoomed grids, and the
  check of :meth:`cvxcontact.contact.truegap.GapDeparture.argmax` against it (tests/test_truegap_argmax.py,
  tests/test_hertz3d.py);
* :func:`line_complementarity`: int lambda^+ (g - [u])^+ of nodal functions on a 2D P1 or P2 line by the 3-point
  Gauss rule, shape functions by hand (tests/test_side_gap_2d.py, tests/test_p2_run_vertex.py).

A fixtures module: the test modules do not import each other.
"""

import itertools

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from cvxcontact.contact.truegap import simplex_grid
from cvxcontact.fem.assembly import assemble


def direct_mixed_solve(scene, sol):
    """Solve the nonsymmetric mixed system (26) with the contact held closed on the active set.

    Independent of the convex model: dense LU of the SI system (rows and columns
    equilibrated by the material constants), unknowns (u_free, phi_free, y_active).
    Returns nodal u (per body), phi (per body), lambda on the merged mesh.
    """
    itf = scene.interface
    blocks, rhs, jumps, slices, pos = [], [], [], [], 0
    for k, body in enumerate(scene.bodies):
        s = assemble(body)
        uf = s.u_free
        J = itf.jump(k, len(body.mesh.points)).toarray()[:, uf]
        c0 = np.abs(body.material.c).max()
        if s.piezoelectric:
            pf = s.phi_free
            e0 = np.abs(s.Kpp.diagonal()).max()
            Kuu, Kup, Kpp = (s.Kuu[uf][:, uf].toarray(), s.Kup[uf][:, pf].toarray(), s.Kpp[pf][:, pf].toarray())
            A = np.block([[Kuu, Kup], [-Kup.T, Kpp]])
            d = np.concatenate([np.full(len(uf), 1 / np.sqrt(c0)), np.full(len(pf), 1 / np.sqrt(e0))])
            b = np.concatenate([s.f[uf], s.q[pf]])
            J = np.hstack([J, np.zeros((len(J), len(pf)))])
        else:
            A = s.Kuu[uf][:, uf].toarray()
            d = np.full(len(uf), 1 / np.sqrt(c0))
            b = s.f[uf]
        blocks.append((A, d))
        rhs.append(b)
        jumps.append(J)
        slices.append((s, slice(pos, pos + len(b))))
        pos += len(b)
    A = sla.block_diag(*[a for a, _ in blocks])
    D = np.concatenate([d for _, d in blocks])
    J = np.hstack(jumps)
    act = np.flatnonzero(sol.contact.active)
    G = J[act]
    n, m = A.shape[0], len(act)
    K = np.block([[D[:, None] * A * D[None, :], (D[:, None] * G.T)], [G * D[None, :], np.zeros((m, m))]])
    z = np.linalg.solve(K, np.concatenate([D * np.concatenate(rhs), np.zeros(m)]))
    x, y = D * z[:n], z[n:]
    us, phis = [], []
    for body, (s, sl) in zip(scene.bodies, slices):
        xb = x[sl]
        u = np.zeros(2 * len(body.mesh.points))
        u[s.u_free] = xb[: len(s.u_free)]
        us.append(u.reshape(-1, 2))
        if s.piezoelectric:
            p = np.zeros(len(body.mesh.points))
            p[s.phi_free] = xb[len(s.u_free):]
            phis.append(p)
        else:
            phis.append(None)
    force = np.zeros(itf.size)
    force[act] = y
    lam = np.linalg.solve(itf.mass.toarray(), force)
    return us, phis, lam, force, J @ x


def dense_kkt(A, F, G, g):
    """A mixed-system callable of the form :func:`cvxcontact.backends.full.mixed_kkt` returns, dense: one body
    with stiffness A (SPD), load F and contact rows G x <= g."""
    n = len(F)

    def kkt(active):
        Ga = G[active]
        K = np.block([[A, Ga.T], [Ga, np.zeros((len(Ga), len(Ga)))]])
        z = np.linalg.solve(K, np.concatenate([F, g[active]]))
        y = np.zeros(len(g))
        y[active] = z[n:]
        return ([z[:n]], [None], y), y, G @ z[:n] - g, np.abs(z[:n]).max()

    def fields(active, z):
        y = np.zeros(len(g))
        y[active] = z[n:]
        return ([z[:n]], [None], y), y, G @ z[:n] - g, np.abs(z[:n]).max()

    kkt.rows = sp.csr_matrix(G)
    kkt.stack = lambda x: x[0][0]
    kkt.matrix, kkt.rhs, kkt.fields = sp.csr_matrix(A), F, fields     # for the factored steps
    return kkt


def enumerated(A, F, G, g):
    """The minimiser of 1/2 x^T A x - F^T x subject to G x <= g by trying every set of closed rows whose rows
    are independent: the one whose forces are >= 0 and every row feasible (independent of the finish; sets
    whose mixed matrix is singular, rows not holding A's kernel, are skipped)."""
    m = len(g)
    for k in range(m + 1):
        for rows in itertools.combinations(range(m), k):
            Ga = G[list(rows)]
            if k and np.linalg.matrix_rank(Ga) < k:
                continue
            K = np.block([[A, Ga.T], [Ga, np.zeros((k, k))]])
            if np.linalg.matrix_rank(K) < len(K):
                continue
            z = np.linalg.solve(K, np.concatenate([F, g[list(rows)]]))
            x, y = z[:len(F)], z[len(F):]
            if (y >= -1e-12).all() and (G @ x - g <= 1e-12).all():
                return x
    raise AssertionError("no active set solves the problem")


def dense_newton(bulk, f, G, g):
    """An independent solution of the Signorini problem of one elastic body with the energy ``bulk`` (its value,
    gradient and Hessian, checked against differences below), the loads ``f`` and the rows G z <= g (dense):
    primal-dual active-set steps from the rows penetrating at z = 0, each with Newton steps on the equality
    constrained problem (dense solves; the first step of a set whole, then halved until the energy does not
    increase) until the step is at rounding. Returns (z, y, active)."""
    z, active = np.zeros(G.shape[1]), g < 0
    for _ in range(30):
        for k in range(50):
            H, r = bulk.hessian(z).toarray(), bulk.gradient(z) - f
            GA = G[active]
            M = np.block([[H, GA.T], [GA, np.zeros((len(GA), len(GA)))]])
            sol = np.linalg.solve(M, np.concatenate([-r, g[active] - GA @ z]))
            dz, t = sol[:len(z)], 1.0
            energy = lambda v: bulk.value(v) - f @ v                                     # noqa: E731
            while k and t > 1e-10 and energy(z + t * dz) > energy(z):
                t /= 2
            z = z + t * dz
            y = np.zeros(len(g))
            y[active] = sol[len(z):]
            if np.abs(t * dz).max() <= 1e-15 * np.abs(z).max():
                break
        slack = G @ z - g
        new = (active & (y >= 0)) | (slack > 1e-14 * np.abs(g).max())
        if (new == active).all():
            return z, y, active
        active = new
    raise AssertionError("the dense active-set steps did not settle")


def true_slack(dep, b, el, L):
    """s (k,) at the full barycentric points L (k, c) of the elements el (k,), from its definition."""
    point = L[:, 1] if dep.width == 3 else L
    return (dep.shape.basis(point) * b[el]).sum(axis=1) - dep.at(el, point)


def slack_maximum(dep, b, m, n=6, steps=3000):
    """(S,) the maximum of s on each curved element: a dense grid of m intervals, then from every local maximum
    of it a local grid of (2n + 1)^(c-1) points of spacing h clipped to the element, recentred on its best
    point, h divided by 4 where that stays within n/2 of the centre (else followed along a ridge), down to
    1e-14."""
    on = np.flatnonzero(dep.curved)
    seg = dep.width == 3
    I = np.arange(m + 1)[:, None] if seg else np.rint(simplex_grid(m)[:, :2] * m).astype(int)   # grid coordinates
    full = lambda z: np.column_stack([1 - z[:, 0], z[:, 0]]) if seg else np.column_stack([z, 1 - z.sum(axis=1)])
    s = true_slack(dep, b, np.repeat(on, len(I)), np.tile(full(I / m), (len(on), 1))).reshape(len(on), -1)
    index = {tuple(p): k for k, p in enumerate(I)}
    moves = [(1,), (-1,)] if seg else [(1, 0), (-1, 0), (0, 1), (0, -1), (1, -1), (-1, 1)]
    nb = np.array([[index.get(tuple(p + np.array(d)), -1) for d in moves] for p in I])
    peak = (s[:, :, None] >= np.where(nb >= 0, s[:, np.maximum(nb, 0)], -np.inf)).all(axis=2)
    which, j = np.nonzero(peak)
    z, val, h = I[j] / m, s[which, j], np.full(len(j), 1.0 / m)
    offsets = (np.arange(-n, n + 1)[:, None] if seg else
               np.stack(np.meshgrid(np.arange(-n, n + 1), np.arange(-n, n + 1), indexing="ij"), -1).reshape(-1, 2))
    live = np.arange(len(j))
    for _ in range(steps):
        Z = np.clip(z[live, None, :] + h[live, None, None] * offsets[None], 0.0, 1.0)
        if not seg:
            over = Z.sum(axis=2) > 1
            Z[over] /= Z.sum(axis=2)[over][:, None]
        sv = true_slack(dep, b, np.repeat(on[which[live]], len(offsets)),
                   np.clip(full(Z.reshape(-1, Z.shape[2])), 0.0, None)).reshape(len(live), -1)
        k = np.argmax(sv, axis=1)
        r = np.arange(len(live))
        far = np.abs(Z[r, k] - z[live]).max(axis=1) > n / 2 * h[live]
        up = sv[r, k] > val[live]
        z[live[up]], val[live[up]] = Z[r, k][up], sv[r, k][up]
        h[live[~(up & far)]] /= 4
        live = live[h[live] > 1e-14]
        if not len(live):
            break
    assert not len(live)
    out = np.full(len(dep.curved), -np.inf)
    np.maximum.at(out, on[which], val)
    return out[on]


def check_argmax(dep, b, m, tol):
    """argmax against the reference: every start converged; (the largest difference, the slack's scale)."""
    best, point, (el, L, v, stop) = dep._argmax(b)
    on = np.flatnonzero(dep.curved)
    assert len(el) >= len(on) and np.all(stop == 0), np.bincount(stop)     # Newton converged at every start
    assert np.all(np.isin(on, el))
    # the point returned gives the value returned
    np.testing.assert_array_equal(true_slack(dep, b, on, dep._full(point[on])), best[on])
    scale = np.abs(b[on]).max(axis=1) + abs(dep.scale) * np.abs(dep.nodal[on]).max(axis=1)
    diff = np.abs(best[on] - slack_maximum(dep, b, m)) / scale
    assert diff.max() <= tol, diff.max()
    return diff.max()


def line_complementarity(x, lam, opening, degree):
    """int lambda^+ (g - [u])^+ (J/m) over the 2D line of sorted nodes ``x`` (m; P2: vertex, midpoint, vertex, ...)
    of the P1 (``degree`` 1) or P2 functions of nodal values ``lam`` (Pa) and ``opening`` g - [u] (m), by the
    3-point Gauss rule on each segment, the shape functions written here."""
    x, lam, opening = (np.asarray(v, dtype=float) for v in (x, lam, opening))
    t = 0.5 + 0.5 * np.array([-np.sqrt(0.6), 0.0, np.sqrt(0.6)])
    w = np.array([5.0, 8.0, 5.0]) / 18.0
    if degree == 1:
        shape, nodes = np.column_stack([1 - t, t]), np.arange(len(x) - 1)[:, None] + np.arange(2)
    else:
        shape = np.column_stack([(1 - t) * (1 - 2 * t), 4 * t * (1 - t), t * (2 * t - 1)])
        nodes = 2 * np.arange((len(x) - 1) // 2)[:, None] + np.arange(3)
    h = x[nodes[:, -1]] - x[nodes[:, 0]]
    at = np.maximum(lam[nodes] @ shape.T, 0.0) * np.maximum(opening[nodes] @ shape.T, 0.0)      # (segments, 3)
    return float(h @ (at @ w))
