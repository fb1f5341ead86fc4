"""Where the Newton steps on the mixed system stop (docs/formulation.md §19): one solve of the circle pressed 5 mm
into a Hencky block (tests/hencky_scenes.py ``indented``), nx x ny cells, by ``method`` ("newton": the fast
route; "full": the interior point and the Newton finish), with the finish's steps, relative residuals, the largest
eps (|K||x|)_i / S_i at the answer ("floor") and the final residual in units of eps (|K||x|)_i; u and the contact
forces saved to ``out.npz`` to compare checkouts (run it with each checkout's root, one thread):

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python benchmarks/newton_floor.py ROOT METHOD NX NY OUT
"""
import sys
import time
import warnings

import numpy as np

root, method, nx, ny, outp = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), sys.argv[5]
sys.path.insert(0, root); sys.path.insert(0, root + "/tests")
import cvxcontact as cc

assert cc.__file__.startswith(root), cc.__file__
import scipy.sparse as sps
from hencky_scenes import NU, SIGMA_Y, E, H, indented

from cvxcontact.backends import nonlinear, signorini

rec = {}
def wrap(mod):
    f = mod.solve_sparse_compliance
    def w(op, G, g, weights, law, x0, *a, **kw):
        out = f(op, G, g, weights, law, x0, *a, **kw)
        if isinstance(out, tuple):
            x, y = out[0], out[1]
            G = sps.csr_matrix(G)
            D = np.asarray(weights) * law.derivative(G @ x - g)
            K = sps.csr_matrix(op.tangent(x) + G.T @ sps.diags(D) @ G)
            S = op.magnitude(x) + abs(G).T @ np.abs(y)
            res = np.abs(op.gradient(x) + G.T @ y)
            Sc = np.maximum(S, 1e-14 * S.max())
            rec["floor"] = float((np.finfo(float).eps * (abs(K) @ np.abs(x)) / Sc).max())
            rec["nfloor"] = float((np.diff(K.indptr) * np.finfo(float).eps * (abs(K) @ np.abs(x)) / Sc).max())
            rec["final_vs_epsKx"] = float((res / np.maximum(np.finfo(float).eps * (abs(K) @ np.abs(x)), 1e-300)).max())
            rec["steps"], rec["history"] = out[4], list(out[5])
        else:
            rec["declined"] = str(out)
        return out
    mod.solve_sparse_compliance = w
wrap(nonlinear); wrap(signorini)
scene = indented(cc.materials.hencky(E, NU, SIGMA_Y, H), nx=nx, ny=ny, depth=5e-3)
solver = cc.ContactSolver(scene, method=method, estimate=False)
with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    t0 = time.process_time(); sol = solver.solve(); cpu = time.process_time() - t0
rep = sol.report()
print(f"{root} {method} {nx}x{ny}: unknowns {solver.problem.unknowns}, cpu {cpu:.1f}s, polished {sol.polished}, ok {sol.ok}, "
      f"route {sol.info.route}, iterations {sol.info.iterations}, finish {sol.info.finish}")
print({k: v for k, v in rec.items()})
print("\n".join(l for l in rep.splitlines() if any(w in l for w in ("equilibrium", "complementarity", "feasibility", "law", "cone"))))
np.savez(outp, u=np.concatenate([np.ravel(u) for u in sol.u]), force=np.asarray(sol.contact.force), cpu=cpu,
         polished=sol.polished, ok=sol.ok, unknowns=solver.problem.unknowns)
