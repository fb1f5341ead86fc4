"""Check: the outputs the element seam (fem/trace.py, Space.node_set/trace/corner_gradients) now computes are
bitwise those of another checkout (e.g. the commit before it).

For 2D P1/P2 ("gamma3", "sigma1"; Signorini and a normal-compliance law; tests/conftest.py's two_blocks) and 3D
P1/P2 tetrahedra ("sigma1", "gamma3"; tests/scenes3d.py's stacked blocks and PZT layer): the contact pressure,
constrained and active nodes, measure, each side's traction and lumped lengths, the contact fraction, the
electrodes, the displacements, the residual estimate's indicators, the VTK cells and von Mises stress of the
output; and the friction laws' scenes (tests/friction_scenes.py: Tresca and Coulomb beside a compliance wall, under
a force-controlled plane, beside a compliance lid, a P2 nodal pair, the P2 "gamma3" cones, a Hencky block, a 3D
cube under a force-controlled lid, 3D blocks dragged on P1 "gamma3" rows; P2 "gamma3" friction beside a nodal pair,
the cones' rows on E's: a 2D stack stuck and rolled, a 3D one stuck), dependent rows beside a compliance law (three
3D blocks on non-matching faces) and the P2 cones beside a compliance law (2D and 3D stacks, Signorini and limited
"gamma3" pairs): the displacements, each pair's lambda,
slip, shear force and threshold, the obstacles' translations and forces, the checks. Each checkout runs in its own
process (PYTHONPATH); the arrays are compared with ``np.array_equal``::

    python benchmarks/seams_unchanged.py OTHER_CHECKOUT [THIS_CHECKOUT]

(OTHER_CHECKOUT: a directory holding a ``cvxcontact`` package, e.g. ``git archive 559c080 cvxcontact | tar -x
-C /tmp/base``.)
"""

import os
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


def outputs(path):
    """The arrays of module docstring, computed by the cvxcontact on sys.path, saved to ``path`` (npz)."""
    sys.path.insert(0, str(HERE.parent / "tests"))
    from conftest import two_blocks
    from scenes3d import pzt_layer_on_plane, stacked_blocks

    import cvxcontact as cc
    from cvxcontact.fem.space import space
    from cvxcontact.io.output import _lengths, body_mesh

    warnings.simplefilter("ignore")
    out = {}
    cases = [(f"2d_d{d}_{c}_{'c' if law else 's'}", lambda: two_blocks(scale=0.01), d, c, law)
             for d in (1, 2) for c in ("gamma3", "sigma1") for law in (None, cc.NormalCompliance(1e12))]
    cases += [(f"{name}_d{d}_{c}", make, d, c, None) for name, make in
              (("stack", lambda: stacked_blocks(lower=(3, 3), upper=(4, 2))), ("pzt", pzt_layer_on_plane))
              for d in (1, 2) for c in ("sigma1", "gamma3")]
    for key, make, degree, cond, law in cases:
        sol = cc.solve(make(), cond, degree=degree, estimate=law is None, **({} if law is None else {"law": law}))
        c = sol.contact
        out |= {key + "_pressure": c.pressure, key + "_constrained": c.constrained, key + "_active": c.active,
                key + "_measure": np.zeros(0) if c.measure is None else c.measure, key + "_u0": sol.u[0],
                key + "_fraction": np.array(np.nan if sol.contact_fraction() is None else sol.contact_fraction()),
                key + "_electrodes": np.array([[e.potential, e.charge] for e in sol.electrodes]).reshape(-1, 2)}
        for k in range(len(sol.scene.interfaces[0].traces)):
            out[key + f"_traction{k}"] = sol.traction(k)[1]
            out[key + f"_lengths{k}"] = _lengths(sol, k)
        if law is None:
            out[key + "_eta"] = np.concatenate([np.asarray(i) for i in sol.estimate.indicators])
        b = sol.scene.bodies[0]
        m = body_mesh(b, sol.u[0], sol.phi[0], space(degree, b.mesh.cell).nodes(b))
        out[key + "_vtk"], out[key + "_vm"] = m.cells[0].data, m.cell_data["von Mises stress [Pa]"][0]
    out |= friction_outputs() | dependent_outputs() | mixed_outputs()
    np.savez(path, **out)


def dependent_outputs():
    """Dependent rows beside a compliance law (tests/stack_scenes.py's three blocks on non-matching faces, "gamma3":
    the Newton steps on the law around the finish of dependent rows): the fields, pressures and checks."""
    from stack_scenes import DELTA3, three_blocks_3d

    import cvxcontact as cc

    k = 1e12
    quadratic = cc.NormalCompliance(stiffness=1e16, exponent=2)             # tests/test_finish3d.py's
    limited = cc.NormalCompliance(stiffness=k, penetration_limit=DELTA3 / 2)
    out = {}
    for key, laws in (("three_quadratic", (cc.Signorini(), quadratic)), ("three_limited", (limited, limited))):
        sol = cc.solve(three_blocks_3d(("gamma3", "gamma3"), laws))
        out |= {f"{key}_u{i}": u for i, u in enumerate(sol.u)}
        out |= {f"{key}_{i}_lam": c.lam for i, c in enumerate(sol.contacts)}
        out[key + "_checks"] = np.array(sorted(sol.residuals().items()), dtype=object)[:, 1].astype(float)
        out[key + "_finish"] = np.array([sol.polished, "independent" in str(sol.info.finish)])
    return out


def mixed_outputs():
    """The P2 "gamma3" cones beside a compliance law (tests/stack_scenes.py's three blocks, 2D and 3D; a Signorini
    "gamma3" pair beside a compliant nodal one, a limited compliant "gamma3" pair beside a Signorini one): the
    fields, lambda and the checks."""
    from stack_scenes import DELTA3, three_blocks, three_blocks_3d

    import cvxcontact as cc

    def stack2d(laws, conditions):
        bodies, pairs, _ = three_blocks(conditions)
        return cc.Scene(*bodies, contacts=[p.with_changes(law=lw) for p, lw in zip(pairs, laws)])

    limited = cc.NormalCompliance(stiffness=1e12, penetration_limit=DELTA3 / 2)
    cases = [("mixed2d_cone_nodal", lambda: stack2d((cc.Signorini(), cc.NormalCompliance(1e11)),
                                                    ("gamma3", "sigma1"))),
             ("mixed2d_limited", lambda: stack2d((cc.NormalCompliance(1e11, penetration_limit=1e-5), cc.Signorini()),
                                                 ("gamma3", "gamma3"))),
             ("mixed3d_cone", lambda: three_blocks_3d(("gamma3", "gamma3"), (cc.Signorini(), limited))),
             ("mixed3d_limited", lambda: three_blocks_3d(("gamma3", "sigma1"), (limited, cc.Signorini())))]
    out = {}
    for key, make in cases:
        sol = cc.solve(make(), degree=2, tol=1.0)
        out |= {f"{key}_u{i}": u for i, u in enumerate(sol.u)}
        out |= {f"{key}_{i}_lam": c.lam for i, c in enumerate(sol.contacts)}
        out[key + "_checks"] = np.array(sorted(sol.residuals().items()), dtype=object)[:, 1].astype(float)
    return out


def friction_outputs():
    """The friction scenes' arrays (module docstring)."""
    from friction_scenes import (
        FLOOR3D,
        P,
        dragged_blocks3d,
        lidded,
        pair2d,
        rolled_stack,
        sheared_hencky,
        steel,
        uniform_stack,
        uniform_stack3d,
        walled,
    )

    import cvxcontact as cc

    def cube(force=-P):                               # tests/test_friction_beside.py's 3D forced lid
        body = cc.Body(cc.box(nx=2, ny=2, nz=2), steel(), contact="bottom",
                       traction={"right": (0.0, 0.05 * P * np.cos(0.5), 0.05 * P * np.sin(0.5))})
        lid = cc.Rigid.plane(point=(0.0, 0.0, 1.0), normal=(0.0, 0.0, -1.0), force=(0.0, 0.0, force))
        return cc.Scene(body, contacts=[cc.Contact(body, "bottom", FLOOR3D, law=cc.Coulomb(0.3)),
                                        cc.Contact(body, "top", lid)])

    k = 1e13
    cases = [("walled_tresca_compliance", lambda: walled(cc.Tresca(1e5), cc.NormalCompliance(k)), {}),
             ("walled_coulomb_compliance2", lambda: walled(cc.Coulomb(0.3), cc.NormalCompliance(1e16, exponent=2.0)),
              {}),
             ("lidded_coulomb", lambda: lidded(cc.Coulomb(0.3)), {}),
             ("lidded_coulomb_compliance", lambda: lidded(cc.Coulomb(0.3), lid_law=cc.NormalCompliance(k)), {}),
             ("lidded_coulomb_p2", lambda: lidded(cc.Coulomb(0.3)), {"degree": 2, "condition": "sigma1"}),
             ("pair_tresca_p2_cones", lambda: pair2d(cc.Tresca(0.03 * P), condition="gamma3"), {"degree": 2}),
             ("pair_coulomb_p2_cones", lambda: pair2d(cc.Coulomb(0.3), condition="gamma3"), {"degree": 2}),
             ("hencky_coulomb", lambda: sheared_hencky(cc.Coulomb(0.6)), {}),
             ("cube_coulomb_forced", cube, {}),
             ("dragged3d_tresca", lambda: dragged_blocks3d(cc.Tresca(2e5)), {"condition": "gamma3"}),
             ("stack_tresca_p2_cones_nodal", lambda: uniform_stack(0.2 * P, cc.Tresca(2 * P), ("gamma3", "sigma1"),
                                                                   (4, 3, 3)), {"degree": 2}),
             ("stack_coulomb_p2_nodal_cones", lambda: uniform_stack(0.2 * P, cc.Coulomb(0.5), ("sigma1", "gamma3"),
                                                                    (3, 3, 5)), {"degree": 2}),
             ("rolled_tresca_p2_cones_nodal", lambda: rolled_stack(cc.Tresca(1e-5 * P), ("gamma3", "sigma1"),
                                                                   nx=(4, 3, 3)), {"degree": 2}),
             ("stack3d_tresca_p2_cones_nodal", lambda: uniform_stack3d(0.2 * P, cc.Tresca(2 * P),
                                                                       ("gamma3", "sigma1")), {"degree": 2})]
    out = {}
    for key, make, kw in cases:
        sol = cc.solve(make(), **kw)
        out[key + "_u0"] = sol.u[0]
        out[key + "_checks"] = np.array(sorted(sol.residuals().items()), dtype=object)[:, 1].astype(float)
        out[key + "_polished"] = np.array([sol.polished, sol.ok])
        for i, c in enumerate(sol.contacts):
            for f in ("lam", "slip", "shear_force", "threshold"):
                v = getattr(c, f, None)
                out[f"{key}_{i}_{f}"] = np.zeros(0) if v is None else np.asarray(v, dtype=float)
        for i, o in enumerate(sol.obstacles or ()):
            for f in ("translation", "force"):
                v = getattr(o, f, None)
                out[f"{key}_obstacle{i}_{f}"] = np.zeros(0) if v is None else np.asarray(v, dtype=float)
    return out


def main(other, this=str(HERE.parent)):
    with tempfile.TemporaryDirectory() as tmp:
        files = []
        for root in (other, this):
            files.append(Path(tmp) / f"{len(files)}.npz")
            env = dict(os.environ, PYTHONPATH=str(Path(root).resolve()))
            subprocess.run([sys.executable, __file__, "--write", str(files[-1])], env=env, check=True, cwd=tmp)
        a, b = np.load(files[0]), np.load(files[1])
        assert set(a.files) == set(b.files), set(a.files) ^ set(b.files)
        bad = [k for k in a.files if not (a[k].shape == b[k].shape and np.array_equal(a[k], b[k], equal_nan=True))]
        print(f"{len(a.files)} arrays compared; bitwise different: {bad or 'none'}")
        return not bad


if __name__ == "__main__":
    if sys.argv[1] == "--write":
        outputs(sys.argv[2])
    else:
        sys.exit(0 if main(*sys.argv[1:]) else 1)
