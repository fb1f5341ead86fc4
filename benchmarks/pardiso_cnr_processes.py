"""PARDISO's answers across fresh processes: hashes (sha256, 10 hex digits) of u, phi, lambda and the contact
unknowns of ``cc.solve`` on small scenes, and of PARDISO solves with several columns, in ONE process; run it in
several fresh processes (and on two checkouts, interleaved) and compare the lines. ``argv[1]``: the checkout;
``argv[2:]``: the cases (blocks-sparse, blocks-default, blocks-condensed, layer-sparse, layer-default,
layer-condensed, boxes-<sparse|default|amg|full>, nrhs, envswitch). The thread count is MKL's (MKL_NUM_THREADS /
OMP_NUM_THREADS; unset: all cores); the first field prints it. The review of h-cnr's numbers
(benchmarks/results/pardiso_cnr.md)::

    for i in $(seq 10); do for t in . /tmp/main; do env -u OMP_NUM_THREADS -u MKL_NUM_THREADS OPENBLAS_NUM_THREADS=1 \\
        python benchmarks/pardiso_cnr_processes.py $t blocks-sparse blocks-default blocks-condensed layer-sparse \\
        layer-condensed boxes-sparse boxes-default boxes-amg boxes-full nrhs envswitch; done; done
"""

import hashlib
import os
import sys
from pathlib import Path

import numpy as np
import scipy.sparse as sp


def H(*arrs):
    """The first 10 hex digits of the sha256 of the arrays' bytes (nested lists and tuples flattened, None left out)."""
    h = hashlib.sha256()

    def feed(a):
        if isinstance(a, (list, tuple)):
            for e in a:
                feed(e)
        elif a is not None:
            h.update(np.ascontiguousarray(a).tobytes())

    for a in arrs:
        feed(a)
    return h.hexdigest()[:10]


def main(tree, cases):
    sys.path[:0] = [tree, tree + "/tests"]
    import cvxcontact as cc
    from cvxcontact.apps.demo import thin_layer, two_blocks
    from cvxcontact.backends import factor

    assert cc.__file__.startswith(tree), cc.__file__

    def sol(scene, **kw):
        s = cc.solve(scene, **kw)
        return f"{s.method}:{s.ok}:" + H(s.u, s.phi, s.contact.lam, s.contact.x)

    out = [f"mkl_max={factor._load().MKL_Get_Max_Threads()} _threads={factor._threads(None)}"]
    for case in cases:
        if case == "blocks-sparse":
            r = sol(two_blocks(), method="sparse", factorization="pardiso")
        elif case == "blocks-default":
            r = sol(two_blocks())
        elif case == "blocks-condensed":
            r = sol(two_blocks(), method="condensed", factorization="pardiso")
        elif case == "layer-sparse":
            r = sol(thin_layer(200), method="sparse", factorization="pardiso")
        elif case == "layer-default":
            r = sol(thin_layer(200))
        elif case == "layer-condensed":
            r = sol(thin_layer(200), method="condensed", factorization="pardiso")
        elif case.startswith("boxes"):
            from scenes3d import two_boxes
            m = case.split("-")[1]
            kw = {} if m == "default" else {"method": m}
            if m == "full":
                kw["factorization"] = "pardiso"
            r = sol(two_boxes(6, elastic=True), **kw)
        elif case == "nrhs":
            # PardisoSymmetric and PardisoFactorization / PardisoInterior with several columns
            from cvxcontact.backends.condensed import contact_dofs, quasi_definite
            from cvxcontact.backends.sparse import SparseContact
            p = cc.ContactSolver(thin_layer(200), method="sparse").problem
            sc = SparseContact(list(p.blocks), p.E)
            rng = np.random.default_rng(1)
            moves = np.asarray(abs(sc.G).sum(axis=1)).ravel() > 0
            K0, K = sc.matrix(moves), sc.matrix(moves & (rng.random(sc.m) < 0.6))
            B = rng.standard_normal((K.shape[0], 5))
            h = factor.PardisoSymmetric(K).analyse(K0)
            X = h.factor(K).solve(B); x1 = h.solve(B[:, 0]); h.release()
            S, _ = quasi_definite(p.blocks[0]); g = contact_dofs(p.blocks[0])
            F = rng.standard_normal((S.shape[0], 4))
            f = factor.factorize(S, g, "pardiso"); y = f.solve(F); f.release()
            rest = np.setdiff1d(np.arange(S.shape[0]), g)
            U = factor.diagonal_stored(sp.triu(sp.csr_matrix(S[rest][:, rest]), format="coo"), sp.csr_matrix)
            fi = factor.PardisoInterior(U); z = fi.solve(F[rest]); fi.release()
            r = H(X) + "," + H(x1) + "," + H(f.schur if hasattr(f, 'schur') else 0, y) + "," + H(z)
        elif case == "envswitch":
            # handle made with MKL_NUM_THREADS unset (MKL default), solved after the env says 1 (sweep workers)
            from cvxcontact.backends.sparse import SparseContact
            p = cc.ContactSolver(thin_layer(200), method="sparse").problem
            sc = SparseContact(list(p.blocks), p.E)
            rng = np.random.default_rng(1)
            moves = np.asarray(abs(sc.G).sum(axis=1)).ravel() > 0
            K0, K = sc.matrix(moves), sc.matrix(moves & (rng.random(sc.m) < 0.6))
            b = rng.standard_normal(K.shape[0])
            h = factor.PardisoSymmetric(K).analyse(K0).factor(K)
            x = h.solve(b)
            os.environ["MKL_NUM_THREADS"] = "1"
            h2 = factor.PardisoSymmetric(K).analyse(K0).factor(K)
            x2 = h2.solve(b)
            x3 = h.solve(b)
            del os.environ["MKL_NUM_THREADS"]
            r = H(x) + "," + H(x2) + "," + H(x3) + f" same13={np.array_equal(x, x3)}"
        else:
            raise SystemExit(case)
        out.append(f"{case}={r}")
    print(" ".join(out), flush=True)


if __name__ == "__main__":
    main(str(Path(sys.argv[1]).resolve()), sys.argv[2:])
