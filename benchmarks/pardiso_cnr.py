"""PARDISO run to run: how many distinct answers one input gives, factorised and solved ``--reps`` times in one
process (each time a new handle: analysis, factorisation, solve), on ``--threads`` MKL threads, with the
adapters' settings or with iparm[1] (the order) and iparm[33] (CNR: the thread count) overridden.

Matrices (``--matrix``): ``layer`` thin_layer(200)'s K(A) as the sparse route factorises it
(:class:`~cvxcontact.backends.factor.PardisoSymmetric` analysed on the bonded values, A = 60 % of the rows some
unknown moves, at random; one random right-hand side); ``box`` the same on two_boxes(n) (3D, elastic; ``--n``); ``schur`` a body of thin_layer(200) condensed on its contact dofs
(:class:`~cvxcontact.backends.factor.PardisoFactorization`: Sigma and a forward/backward sweep); ``interior`` its
S_II alone (:class:`~cvxcontact.backends.factor.PardisoInterior`).

Prints one line: the settings and ``distinct=<k>/<reps> first=<sha256[:12] of the first answer>``; fresh processes
compare their ``first``. Example::

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 PYTHONPATH=$PWD python benchmarks/pardiso_cnr.py --matrix layer \\
        --threads 2 --reps 10 --ordering keep --cnr keep
"""

import argparse
import hashlib
import sys
from pathlib import Path

import numpy as np
import scipy.sparse as sp

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))          # this checkout
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # scenes3d: the scenes


def _override(ordering, cnr):
    """Wrap the adapters' PARDISO call so that iparm[1] / iparm[33] are the given ones ("keep": the adapters')."""
    from cvxcontact.backends import factor

    call = factor.PardisoFactorization._call

    def patched(self, phase, b, x, nrhs=1):
        if ordering != "keep":
            self._iparm[1] = int(ordering)
        if cnr != "keep":
            self._iparm[33] = int(cnr)
        return call(self, phase, b, x, nrhs)

    for cls in (factor.PardisoFactorization, factor.PardisoInterior, factor.PardisoSymmetric):
        cls._call = patched


def _mixed(scene):
    import cvxcontact as cc
    from cvxcontact.backends.sparse import SparseContact

    problem = cc.ContactSolver(scene, method="sparse").problem
    sc = SparseContact(list(problem.blocks), problem.E)
    moves = np.asarray(abs(sc.G).sum(axis=1)).ravel() > 0
    K0, K = sc.matrix(moves), sc.matrix(moves & (np.random.default_rng(5).random(sc.m) < 0.6))
    return K0, K, np.random.default_rng(6).standard_normal(K.shape[0])      # (the loads [F; g]: zero on most rows)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--matrix", choices=["layer", "box", "schur", "interior"], default="layer")
    ap.add_argument("--n", type=int, default=12, help="two_boxes' cells a side (--matrix box)")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--reps", type=int, default=10)
    ap.add_argument("--ordering", default="keep", help="iparm[1]: keep, 0, 2 or 3")
    ap.add_argument("--layer-ordering", type=int, help="PardisoSymmetric(ordering=) for layer / box (default: its)")
    ap.add_argument("--cnr", default="keep", help="iparm[33]: keep or a number")
    args = ap.parse_args()

    from cvxcontact.apps.demo import thin_layer
    from cvxcontact.backends import factor

    _override(args.ordering, args.cnr)
    hashes = []
    if args.matrix in ("layer", "box"):
        if args.matrix == "layer":
            K0, K, b = _mixed(thin_layer(200))
        else:
            from scenes3d import two_boxes
            K0, K, b = _mixed(two_boxes(args.n, elastic=True))
        for _ in range(args.reps):
            kw = {} if args.layer_ordering is None else {"ordering": args.layer_ordering}
            h = factor.PardisoSymmetric(K, threads=args.threads, **kw).analyse(K0)
            x = h.factor(K).solve(b)
            h.release()
            hashes.append(hashlib.sha256(x.tobytes()).hexdigest())
    else:
        import cvxcontact as cc
        from cvxcontact.backends.condensed import (
            contact_dofs,
            quasi_definite,
            quasi_definite_rhs,
        )

        block = cc.ContactSolver(thin_layer(200), method="sparse").problem.blocks[0]
        S, _ = quasi_definite(block)
        F = quasi_definite_rhs(block)
        gamma = contact_dofs(block)
        rest = np.setdiff1d(np.arange(S.shape[0]), gamma)
        for _ in range(args.reps):
            if args.matrix == "schur":
                f = factor.factorize(S, gamma, "pardiso", threads=args.threads)
                fwd = f.forward(F)
                x = f.backward(fwd, np.zeros(len(gamma)))
                out = np.concatenate([f.schur.ravel(), fwd.reduced, x])
            else:
                U = factor.diagonal_stored(sp.triu(sp.csr_matrix(S[rest][:, rest]), format="coo"), sp.csr_matrix)
                f = factor.PardisoInterior(U, threads=args.threads)
                out = f.solve(F[rest])
            f.release()
            hashes.append(hashlib.sha256(out.tobytes()).hexdigest())
    n = K.shape[0] if args.matrix in ("layer", "box") else S.shape[0]
    print(f"matrix={args.matrix} n={n} threads={args.threads} ordering={args.ordering} cnr={args.cnr} "
          f"distinct={len(set(hashes))}/{args.reps} first={hashes[0][:12]}", flush=True)


if __name__ == "__main__":
    main()
