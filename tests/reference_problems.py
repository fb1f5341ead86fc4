"""Reference problems shared by the tests, built independently of the package's contact code.

* Two elastic blocks with nu = 0, clamped at their far ends and pressed together by an interference
  DELTA (gap g = -DELTA): two 1D springs in series (heights H_l, moduli E_l; plane strain with nu = 0
  gives c22 = E). The contact pressure is uniform, lambda = (DELTA - r) / C with C = H1/E1 + H2/E2, and a
  normal-compliance law lambda = k r^m gives the scalar equation r + C k r^m = DELTA (:func:`closed_form`);
  :func:`field_error` measures a solution's u against the springs' fields.
* Dense contact rows of two horizontal contact parts, test-built from each body's own trace nodes
  (:func:`merged_rows`), and a dense primal-dual active-set solve of the mixed system (26) with them
  (:func:`active_set_solve`), which asserts that its answer satisfies (27).
* Simpson's weights on a P2 line (:func:`simpson`), the rows' weights of a P2 trace whose segments all lie in the
  overlap.
* A piezoelectric layer bonded in uniaxial strain to a steel layer, driven by a surface charge or a
  voltage, with its closed form (:func:`bonded_patch`: u and phi linear in y, lambda uniform).
"""

import numpy as np
from scipy.optimize import brentq

import cvxcontact as cc

E1, E2, H1, H2, DELTA = 70e9, 200e9, 0.5, 0.3, 1e-4
C = H1 / E1 + H2 / E2


def pressed(n1=(7, 3), n2=(5, 2)):
    """Two nu = 0 blocks (7 : 5 cells on Gamma_3 by default: non-matching), interference DELTA."""
    m1 = cc.rectangle(x=(0, 1), y=(0, H1), nx=n1[0], ny=n1[1])
    m2 = cc.rectangle(x=(0, 1), y=(-H2, 0), nx=n2[0], ny=n2[1])
    b1 = cc.Body(m1, cc.materials.isotropic(E=E1, nu=0.0), clamped=["top"], contact="bottom")
    b2 = cc.Body(m2, cc.materials.isotropic(E=E2, nu=0.0), clamped=["bottom"], contact="top")
    return cc.Scene(b1, b2, gap=-DELTA)


def closed_form(k, m, limit=None):
    """(penetration r, pressure lambda) of the springs in series; ``limit`` caps r (a penetration limit)."""
    r = brentq(lambda r: r + C * k * r ** m - DELTA, 0.0, DELTA, xtol=1e-22, rtol=1e-15)
    if limit is not None and r > limit:
        r = limit
    return r, (DELTA - r) / C


def field_error(sol, lam):
    """Largest error of u at every P2 node of both bodies against the springs' fields, over DELTA."""
    err = 0.0
    for k, pts in enumerate(sol.points):
        y = pts[:, 1]
        uy = (lam * H1 / E1) * (1 - y / H1) if k == 0 else -(lam * H2 / E2) * (1 + y / H2)
        err = max(err, np.abs(sol.u[k][:, 1] - uy).max() / DELTA, np.abs(sol.u[k][:, 0]).max() / DELTA)
    return err


def hat(xm, xt):
    """(len(xm), len(xt)): the P1 function with nodes ``xt`` and nodal values e_j, evaluated at ``xm``."""
    P = np.zeros((len(xm), len(xt)))
    for j in range(len(xt)):
        e = np.zeros(len(xt))
        e[j] = 1.0
        P[:, j] = np.interp(xm, xt, e)
    return P


def horizontal_trace(body, part):
    """Nodes of a horizontal part sorted by x, their abscissae, the line's ordinate and the y component of
    the outward normal (-1 for a body above the line)."""
    m = body.mesh
    nodes = np.unique(m.boundary(part))
    nodes = nodes[np.argsort(m.points[nodes, 0])]
    line = float(m.points[nodes, 1].mean())
    return nodes, m.points[nodes, 0], line, (-1.0 if m.points[:, 1].mean() > line else 1.0)


def stiffness(bodies):
    """(systems, offsets, K, f): each body assembled, its free u dofs stacked; K, f dense (SI)."""
    from cvxcontact.fem.assembly import assemble

    systems = [assemble(b) for b in bodies]
    off = np.concatenate([[0], np.cumsum([len(s.u_free) for s in systems])])
    K, f = np.zeros((off[-1], off[-1])), np.zeros(off[-1])
    for s, a, b in zip(systems, off[:-1], off[1:]):
        K[a:b, a:b] = s.Kuu[s.u_free][:, s.u_free].toarray()
        f[a:b] = s.f[s.u_free]
    return systems, off, K, f


def merged_rows(bodies, systems, off, ka, pa, kb, pb):
    """[u_nu] at the merged nodes of the overlap of two horizontal parts: (xs, G, inside), ``xs`` the union
    of both traces' abscissae inside the overlap, ``G`` (len(xs), off[-1]) on the stacked free u dofs and
    ``inside`` each trace's own abscissae inside the overlap (the rows of sigma1 / sigma2)."""
    ta, tb = horizontal_trace(bodies[ka], pa), horizontal_trace(bodies[kb], pb)
    lo, hi = max(ta[1][0], tb[1][0]), min(ta[1][-1], tb[1][-1])
    inside = [t[1][(t[1] >= lo - 1e-12) & (t[1] <= hi + 1e-12)] for t in (ta, tb)]
    xs = np.unique(np.round(np.concatenate(inside), 12))
    G = np.zeros((len(xs), off[-1]))
    for k, t in ((ka, ta), (kb, tb)):
        full = np.zeros((len(xs), 2 * len(bodies[k].mesh.points)))
        full[:, 2 * t[0] + 1] = t[3] * hat(xs, t[1])
        G[:, off[k]:off[k + 1]] += full[:, systems[k].u_free]
    return xs, G, inside


def active_set_solve(K, f, G, g, max_steps=50):
    """Dense primal-dual active-set steps on the KKT system of (26) with the rows G u <= g; asserts (27) of
    the answer to 1e-10 of its own scales. Returns (u, y)."""
    n = len(f)
    c = np.abs(K).max()
    act = np.ones(len(g), bool)
    for _ in range(max_steps):
        m = int(act.sum())
        A = np.block([[K / c, G[act].T], [G[act], np.zeros((m, m))]])
        z = np.linalg.solve(A, np.concatenate([f / c, g[act]]))
        u, y = z[:n], np.zeros(len(g))
        y[act] = z[n:] * c
        slack, scales = G @ u - g, sign_scales(y, g, G @ u)
        new = next_active(act, y, slack, scales)
        if np.array_equal(new, act):
            break
        act = new
    else:
        raise AssertionError("the reference active-set steps did not settle")
    assert_complementary(y, slack, scales)
    return u, y


def sign_scales(y, g, Gu):
    """(force scale, displacement scale) of a reference answer: max |y|, max |g| + max |G u|."""
    return np.abs(y).max(initial=1e-300), np.abs(g).max(initial=0) + np.abs(Gu).max()


def next_active(active, y, slack, scales):
    """The next active set of the reference steps: active rows that keep a positive force, open rows that
    penetrate, each beyond 1e-12 of its scale."""
    ymax, smax = scales
    return np.where(active, y > 1e-12 * ymax, slack > 1e-12 * smax)


def assert_complementary(y, slack, scales):
    """The reference satisfies the signs of (27) to 1e-10 of its scales."""
    ymax, smax = scales
    assert y.min() >= -1e-10 * ymax and slack.max() <= 1e-10 * smax


def per_body(systems, bodies, off, u):
    """The stacked free u dofs -> per-body nodal displacements (n_nodes, 2), zero on the supports."""
    out = []
    for s, b, a, e in zip(systems, bodies, off[:-1], off[1:]):
        full = np.zeros(2 * len(b.mesh.points))
        full[s.u_free] = u[a:e]
        out.append(full.reshape(-1, 2))
    return out


def bonded_patch(n1, n2, q2=-0.08, voltage=None):
    """Uniaxial-strain patch: exact u, phi linear in y, uniform lambda (closed form below).

    The piezo layer (y in [0, 1]) is driven by a surface charge q2 on its contact face
    (grounded on top) or, with ``voltage``, by phi = V on top (grounded on the contact face).
    """
    pzt, steel = cc.materials.PZT5H, cc.materials.isotropic(E=200e9, nu=0.3)
    c13, c33 = pzt.c[0, 1], pzt.c[1, 1]
    e31, e33, k33 = pzt.e[1, 0], pzt.e[1, 1], pzt.kappa[1, 1]
    M2, lame = steel.c[1, 1], steel.c[0, 1]
    if voltage is None:
        alpha = -q2 / (e33 + k33 * (c33 + M2) / e33)   # strain of the piezo layer
        d = -(c33 + M2) * alpha / e33                  # d phi / dy
        phi0 = -d                                      # phi(y) = d (y - 1)
        electric = dict(grounded="top", surface_charge={"bottom": q2})
    else:
        d, phi0 = voltage, 0.0                         # phi(y) = V y
        alpha = -e33 * voltage / (c33 + M2)
        electric = dict(grounded="bottom", potential={"top": voltage})
    sxx1, sxx2 = c13 * alpha + e31 * d, lame * (-alpha)
    m1 = cc.rectangle(x=(0, 1), y=(0, 1), nx=n1, ny=3)
    m2 = cc.rectangle(x=(0, 1), y=(-1, 0), nx=n2, ny=3)
    b1 = cc.Body(m1, pzt, clamped="top", contact="bottom", traction={"left": (-sxx1, 0.0), "right": (sxx1, 0.0)},
                 **electric)
    b2 = cc.Body(m2, steel, clamped="bottom", contact="top", traction={"left": (-sxx2, 0.0), "right": (sxx2, 0.0)})
    exact = dict(u1=lambda p: np.column_stack([0 * p[:, 0], alpha * (p[:, 1] - 1)]),
                 u2=lambda p: np.column_stack([0 * p[:, 0], -alpha * (p[:, 1] + 1)]),
                 phi1=lambda p: phi0 + d * p[:, 1], lam=M2 * alpha)
    return cc.Scene(b1, b2), exact


def simpson(xv):
    """Simpson's weights on the P2 line with sorted vertices ``xv`` (m; interleaved: vertex, midpoint, ...)."""
    h = np.diff(xv)
    w = np.zeros(2 * len(xv) - 1)
    w[0:-1:2] += h / 6
    w[2::2] += h / 6
    w[1::2] = 2 * h / 3
    return w
