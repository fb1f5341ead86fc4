"""Check: the outputs the element seam (fem/trace.py, Space.node_set/trace/corner_gradients) now computes are
bitwise those of another checkout (e.g. the commit before it).

For 2D P1/P2 ("gamma3", "sigma1"; Signorini and a normal-compliance law; tests/conftest.py's two_blocks) and 3D
P1/P2 tetrahedra ("sigma1", "gamma3"; tests/scenes3d.py's stacked blocks and PZT layer): the contact pressure,
constrained and active nodes, measure, each side's traction and lumped lengths, the contact fraction, the
electrodes, the displacements, the residual estimate's indicators, the VTK cells and von Mises stress of the
output. Each checkout runs in its own process (PYTHONPATH); the arrays are compared with ``np.array_equal``::

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
    np.savez(path, **out)


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
