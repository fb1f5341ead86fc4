"""The guaranteed error bound (cvxcontact.error_bound, solve(..., estimate="equilibrated"); docs/accuracy.md).

Checked independently of the code under test: the bound against the true error measured on nested fine
references (the estimate study's prolongation and energy norm); a closed form (a uniaxial block whose exact
solution lies in the P1 space: the bound is rounding); the equilibrium of the stress sampled directly (its
divergence and its normal traction across every edge at points the construction never used); the refusals.
"""

import warnings

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.apps.studies import bound as study
from cvxcontact.solution import bound, equilibration

pytestmark = pytest.mark.numerics   # equilibrated fluxes, sparse saddle-point solves (every kernel set)

# measured effectivity (bound / true error), levels 0, 1 and 2, reference at level 3
# (the pressure minimising the bound; with the lumped pressure: 1.57-2.27, 1.34-1.49, 2.18-2.62, 1.67-1.88)
MEASURED = {"circle (ray), P1": (1.53, 2.21), "crowned block on a plane, P1": (1.34, 1.48),
            "PZT layer, floating electrode, rigid circle, P1": (2.18, 2.58),
            "PZT block, charges, crowned on a plane, P1": (1.67, 1.87)}


def uniaxial(approach=1e-4, nx=4, ny=2):
    mat = cc.materials.isotropic(E=70e9, nu=0.3)
    block = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=nx, ny=ny), mat, roller=["bottom", "left", "right"],
                    contact="top")
    return cc.Scene(block, contacts=[cc.Contact(block, "top", cc.Rigid.plane((0.0, 0.5 - approach), (0.0, -1.0)))])


def test_the_bound_of_an_exact_solution_is_rounding():
    """Uniaxial compression by a rigid plane, rollers elsewhere: u is affine, u_h = u, so the bound is 0 up to
    rounding; its terms: the stress mismatch and the complementarity p (g - u_h . d) at active nodes."""
    sol = cc.solve(uniaxial(), estimate="equilibrated")
    est = sol.estimate
    assert est.kind == "equilibrated" and est.guaranteed is True
    # measured: relative 1.8e-8 (the unsquared complementarity's rounding, 6e-13 J/m against |||u_h|||^2 = 1.9e3)
    assert est.relative < 1e-6
    assert est.parts["stress"] <= 1e-20 * est.norm ** 2          # measured 2.9e-28 / 1.9e3
    # a plane: u_h is admissible between the nodes; the correction only takes the rows' rounding (measured
    # |||w||| = 6.8e-15 against |||u_h||| = 43)
    assert est.parts["correction"] <= 1e-12 * est.norm
    assert "guaranteed" in str(est) and "not guaranteed" not in str(est)


@pytest.mark.parametrize("name", list(MEASURED))          # the pairs: tests/test_bound_pairs.py
def test_the_bound_is_above_the_true_error(name):
    """Levels 0, 1 and 2 against a reference refined three times: the bound exceeds the true error (for the
    piezoelectric scenes in the coupled energy norm of (u, phi)). A guaranteed
    bound exceeds |||u - u_h|||, which for nested spaces is at least the measured |||u_ref - I u_h||| (the
    reference's own error adds to it, Galerkin orthogonality up to the contact's small complementarity): so
    effectivity >= 1 with no margin needed; above, the measured range widened by 3."""
    build, options = study.SCENES[name]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        rows = study.effectivity(build, options, levels=(0, 1, 2), reference=3)
    for r in rows:
        assert r["ok"]
        # the true error is measured against a reference with its own error e_ref <= reference_bound; the
        # error to the continuous solution is >= true_error - e_ref, so the bound must exceed that
        assert r["effectivity"] >= 1.0, r
        assert r["effectivity"] <= MEASURED[name][1] * 3, r
    assert rows[2]["bound"] < rows[1]["bound"] < rows[0]["bound"]


def test_the_stress_is_equilibrated_where_the_construction_did_not_look():
    """The crowned block (body force, traction, prescribed top, contact), level 0, checked from tau's nodal
    values alone: div tau + f = 0 on every sub-triangle (from the barycentric gradients of an independent
    assembly), tau n continuous across every sub-triangle edge shared by two (found from the coordinates) at
    its quarter points, and on the boundary: tau n = t on the right, 0 on the left, tangential 0 and normal
    <= 0 on the contact part, at quarter points (the construction imposes all this at edge ends only)."""
    scene = study.crowned_scene()
    sol = cc.solve(scene, estimate=False)
    tau, v = bound.equilibrated_stress(sol)
    _, _, verts = equilibration._split(scene.bodies[0].mesh)
    scale = np.abs(tau).max()
    f = np.array([0.0, -1e8])
    # the divergence: tau linear, so div = sum_k tau_k . grad L_k with grad L from the vertex coordinates
    d = np.roll(verts, -1, axis=1) - np.roll(verts, 1, axis=1)
    area2 = d[:, 0, 0] * d[:, 1, 1] - d[:, 0, 1] * d[:, 1, 0]
    gL = np.stack([d[:, :, 1], -d[:, :, 0]], axis=2) / area2[:, None, None]          # (s, 3, 2)
    div = np.column_stack([(tau[:, :, 0] * gL[:, :, 0] + tau[:, :, 2] * gL[:, :, 1]).sum(axis=1),
                           (tau[:, :, 2] * gL[:, :, 0] + tau[:, :, 1] * gL[:, :, 1]).sum(axis=1)])
    assert np.abs(div + f).max() <= 1e-8 * np.abs(f).max()                          # measured 2e-14 relative
    # every sub-triangle edge, keyed by its rounded end points
    edges = {}
    for s_ in range(len(verts)):
        for k in range(3):
            a, b = verts[s_, k], verts[s_, (k + 1) % 3]
            key = tuple(sorted([tuple(np.round(a, 12)), tuple(np.round(b, 12))]))
            edges.setdefault(key, []).append((s_, k))

    def traction(s_, k, t, n):                     # tau n at parameter t along local edge k -> k + 1 of s_
        T = (1 - t) * tau[s_, k] + t * tau[s_, (k + 1) % 3]
        return np.array([T[0] * n[0] + T[2] * n[1], T[2] * n[0] + T[1] * n[1]])

    worst, boundary = 0.0, {"left": [], "right": [], "bottom": []}
    for key, owners in edges.items():
        s_, k = owners[0]
        a, b = verts[s_, k], verts[s_, (k + 1) % 3]
        n = np.array([b[1] - a[1], a[0] - b[0]]) / np.linalg.norm(b - a)          # outward of s_
        if len(owners) == 2:
            s2, k2 = owners[1]
            flip = np.allclose(verts[s2, k2], a)
            for t in (0.25, 0.5, 0.75):
                worst = max(worst, np.abs(traction(s_, k, t, n) - traction(s2, k2, 1 - t if not flip else t, n)).max())
        else:
            side = "left" if max(a[0], b[0]) < 1e-12 else "right" if min(a[0], b[0]) > 1 - 1e-12 else \
                "bottom" if max(a[1], b[1]) < 1e-12 else None
            if side:
                boundary[side] += [traction(s_, k, t, n) for t in (0.25, 0.5, 0.75)]
    assert worst <= 1e-9 * scale                                                     # measured 3e-15 relative
    assert np.abs(np.array(boundary["left"])).max() <= 1e-9 * scale
    assert np.abs(np.array(boundary["right"]) - [2e6, 0.0]).max() <= 1e-9 * scale
    bottom = np.array(boundary["bottom"])                                            # outward normal (0, -1)
    assert np.abs(bottom[:, 0]).max() <= 1e-9 * scale and (bottom[:, 1] >= -1e-9 * scale).all()
    assert bottom[:, 1].max() > 0.1 * scale                                          # the contact pushes up
    # v is admissible: d . v <= g at many points of the crowned bottom (d = (0, -1), g = 2e-3 (x - 0.5)^2)
    mesh = scene.bodies[0].mesh
    e = mesh.boundary("bottom")
    t = np.linspace(0, 1, 101)[:, None, None]
    x = (1 - t) * mesh.points[e[:, 0]] + t * mesh.points[e[:, 1]]
    vy = (1 - t[..., 0]) * v[e[:, 0], 1] + t[..., 0] * v[e[:, 1], 1]
    assert (-vy <= 2e-3 * (x[..., 0] - 0.5) ** 2 + 1e-15).all()


def pzt_uniaxial(**electric):
    """uniaxial() made of PZT-5A, grounded along its bottom, with ``electric`` conditions on its top."""
    block = cc.Body(cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=4, ny=2), cc.materials.PZT5A,
                    roller=["bottom", "left", "right"], contact="top", grounded=["bottom"], **electric)
    return cc.Scene(block, contacts=[cc.Contact(block, "top", cc.Rigid.plane((0.0, 0.5 - 1e-4), (0.0, -1.0)))])


@pytest.mark.parametrize("electric", [dict(surface_charge={"top": 0.01}), dict(floating={"top": 0.002}),
                                      dict(potential={"top": 100.0})], ids=["charge", "floating", "driven"])
def test_the_piezoelectric_bound_of_an_exact_solution_is_rounding(electric):
    """The PZT uniaxial block (poled along y): strain, potential gradient, stress and electric displacement
    uniform satisfy the rollers (sigma_xy = 0 and D_x = 0 as eps_xy = E_x = 0), the contact and the top's
    electric condition (D_y = q2 for a charge, D_y = -Q / 1 m for a floating charge Q, any uniform D_y for a
    driven electrode): (u, phi) is in the P1 space, the bound is rounding. The electric term vanishes only if
    the flux's conditions carry the solver's signs (a floating charge with the wrong sign leaves
    kappa^{-1/2} 2 Q in it)."""
    sol = cc.solve(pzt_uniaxial(**electric), estimate="equilibrated")
    est = sol.estimate
    assert est.guaranteed and est.kind == "equilibrated"
    # measured: relative 1.5e-8 (charge), 2.0e-8 (floating), 1.7e-8 (driven): the complementarity's rounding
    assert est.relative < 1e-6
    # measured 1.2e-27, 2.4e-28, 1.1e-28 J/m against |||(u_h, phi_h)|||^2 = 1.4e4, 2.3e3, 2.2e3
    assert est.parts["electric"] <= 1e-20 * est.norm ** 2
    assert est.parts["stress"] <= 1e-20 * est.norm ** 2        # measured 5.2e-24, 2.7e-25, 2.8e-28 J/m


def test_the_electric_displacement_is_equilibrated_where_the_construction_did_not_look():
    """The charged PZT block of the study (volume charge, surface charge on the left, grounded top), level 0,
    checked from D~'s vertex values alone: div D~ = q0 on every triangle (from the barycentric gradients of the
    vertex coordinates), D~ . n continuous across every interior edge (found from the coordinates) at its
    quarter points, D~ . n = q2 on the left, 0 on the right and the bottom; and the floating layer's total
    flux through its top 0 (its charge) while D~ . n varies along it."""
    scene = study.charged_block_scene()
    sol = cc.solve(scene, estimate=False)
    D = bound.equilibrated_displacement(sol)
    mesh = scene.bodies[0].mesh
    verts = mesh.points[mesh.triangles]
    d = np.roll(verts, -1, axis=1) - np.roll(verts, 1, axis=1)
    area2 = d[:, 0, 0] * d[:, 1, 1] - d[:, 0, 1] * d[:, 1, 0]
    gL = np.stack([d[:, :, 1], -d[:, :, 0]], axis=2) / area2[:, None, None]          # (m, 3, 2)
    div = np.einsum("mkd,mkd->m", D, gL)
    scale = np.abs(D).max()
    assert np.abs(div - 0.05).max() <= 1e-9 * 0.05                                  # measured 6.4e-15 relative
    edges = {}
    for c in range(len(verts)):
        for k in range(3):
            a, b = verts[c, k], verts[c, (k + 1) % 3]
            edges.setdefault(tuple(sorted([tuple(np.round(a, 12)), tuple(np.round(b, 12))])), []).append((c, k))

    def flux(c, k, t, n):
        return ((1 - t) * D[c, k] + t * D[c, (k + 1) % 3]) @ n

    worst, sides = 0.0, {"left": [], "right": [], "bottom": []}
    for owners in edges.values():
        c, k = owners[0]
        a, b = verts[c, k], verts[c, (k + 1) % 3]
        n = np.array([b[1] - a[1], a[0] - b[0]]) / np.linalg.norm(b - a)
        if len(owners) == 2:
            c2, k2 = owners[1]
            flip = np.allclose(verts[c2, k2], a)
            for t in (0.25, 0.5, 0.75):
                worst = max(worst, abs(flux(c, k, t, n) - flux(c2, k2, t if flip else 1 - t, n)))
        else:
            side = "left" if max(a[0], b[0]) < 1e-12 else "right" if min(a[0], b[0]) > 1 - 1e-12 else \
                "bottom" if max(a[1], b[1]) < 1e-12 else None
            if side:
                sides[side] += [flux(c, k, t, n) for t in (0.25, 0.5, 0.75)]
    assert worst <= 1e-9 * scale                                                      # measured 1.2e-16 relative
    assert np.abs(np.array(sides["left"]) + 0.05).max() <= 1e-9 * scale             # measured 6e-17
    assert np.abs(np.array(sides["right"])).max() <= 1e-9 * scale                   # measured 4e-20
    assert np.abs(np.array(sides["bottom"])).max() <= 1e-9 * scale                  # measured 5e-20
    # the floating electrode: its total flux is its charge, its normal flux is left free along it
    layer = study.floating_layer_scene()
    sol = cc.solve(layer, estimate=False)
    D = bound.equilibrated_displacement(sol)
    mesh = layer.bodies[0].mesh
    top = []
    for c, tri in enumerate(mesh.triangles):
        for k in range(3):
            a, b = mesh.points[tri[k]], mesh.points[tri[(k + 1) % 3]]
            if min(a[1], b[1]) > 0.2 - 1e-12:
                top.append((np.linalg.norm(b - a), 0.5 * (D[c, k, 1] + D[c, (k + 1) % 3, 1])))   # n = (0, 1)
    top = np.array(top)
    assert abs(top[:, 0] @ top[:, 1]) <= 1e-9 * np.abs(top[:, 1]).max()             # measured 1e-17
    assert np.abs(top[:, 1]).max() > 1e-3 * np.abs(D).max()         # not merely zero: measured 1.0 (its largest)


def test_uncovered_cases_are_refused_naming_what_is_covered():
    mesh3 = cc.box(x=(0.0, 1.0), y=(0.0, 1.0), z=(0.0, 0.5), nx=2, ny=2, nz=1)
    block3 = cc.Body(mesh3, cc.materials.isotropic(E=70e9, nu=0.3), clamped="bottom", contact="top")
    scene3 = cc.Scene(block3, contacts=[cc.Contact(block3, "top", cc.Rigid.plane((0.0, 0.0, 0.5 - 1e-4),
                                                                                 (0.0, 0.0, -1.0)))])
    with pytest.raises(cc.UnsupportedError, match="3D.*it covers 2D P1"):
        cc.solve(scene3, estimate="equilibrated")
    with pytest.raises(cc.UnsupportedError, match="P2.*it covers 2D P1"):
        cc.solve(uniaxial(), estimate="equilibrated", degree=2)
    with pytest.raises(cc.UnsupportedError, match="compliance"):
        cc.solve(uniaxial(), estimate="equilibrated", law=cc.NormalCompliance(1e12))
    with pytest.raises(cc.UnsupportedError, match="closest point; distance='ray'"):
        cc.solve(study.circle_scene(distance="closest"), estimate="equilibrated")
    from cvxcontact.apps.studies import estimate as residual_study
    with pytest.raises(cc.UnsupportedError, match="pair of deformable bodies under condition 'sigma1'.*gamma3"):
        cc.solve(residual_study.blocks_scene(), estimate="equilibrated", condition="sigma1")
    with pytest.raises(cc.UnsupportedError, match="P2"):                  # the function refuses a solved P2 too
        cc.error_bound(cc.solve(uniaxial(), degree=2, estimate=False))
    with pytest.raises(cc.SolverError, match="equilibrated"):
        cc.solve(uniaxial(), estimate="guaranteed")
    with pytest.raises(cc.UnsupportedError, match="charges given as functions"):
        cc.solve(pzt_uniaxial(volume_charge=lambda x, y: 0.1 * x), estimate="equilibrated")
    with pytest.raises(cc.UnsupportedError, match=r"contacts\[0\]: a pair .* condition 'sigma1'"):   # its own condition
        cc.solve(residual_study.stack_scene(), estimate="equilibrated", condition="gamma3")
    with pytest.raises(cc.UnsupportedError, match="friction"):
        cc.solve(uniaxial(), estimate="equilibrated", law=cc.Tresca(1e6))
    with pytest.raises(cc.UnsupportedError, match="body 0 is elastic"):
        bound.equilibrated_displacement(cc.solve(uniaxial(), estimate=False))
