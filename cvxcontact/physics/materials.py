"""Constitutive laws: piezoelectric (stress-charge form) and isotropic elastic, in 3D and in their plane
reductions (plane strain by default, plane stress with ``material.plane_stress()``), poling axis along the
last axis (z in 3D, y in 2D) or turned (``material.rotated(R)``: a 3x3 rotation, or an angle in 2D).

3D (docs/materials.md §3): Voigt order (xx, yy, zz, yz, xz, xy), engineering shear strains, field (Ex, Ey, Ez):

    sigma = c eps - e^T E,     D = e eps + kappa E,     E = -grad(phi)

    c (6, 6) Pa, hexagonal 6mm: c11, c12, c13, c33, c44 and c66 = (c11 - c12) / 2
    e (3, 6) C/m^2: e15 at (x, xz) and (y, yz); e31 at (z, xx), (z, yy); e33 at (z, zz)
    kappa = diag(eps11, eps11, eps33) (F/m, clamped permittivities)

(``material.c3``, ``e3``, ``kappa3``; ``material.tensors(dim)``). The 2D model plane is the crystal's
(x1, x3) plane (2D y = 3D z): the plane-strain matrices ``c`` (3, 3), ``e`` (2, 3), ``kappa`` (2, 2) are the
rows and columns (xx, zz, xz) of c, the rows (D_x, D_z) and those columns of e, the (x, z) block of kappa:

    c = [[c11, c13, 0], [c13, c33, 0], [0, 0, c44]]     (Pa)
    e = [[0, 0, e15], [e31, e33, 0]]                     (C/m^2, rows D1, D3)
    kappa = diag(eps11, eps33)                           (F/m)

``c12`` enters the plane problem only through the out-of-plane stress sigma22. A material given by its
plane constants alone (no ``c12``, or 2D matrices) has no 3D tensors: a 3D body refuses it.
Built-in constants: ``docs/materials.md`` §1 (Berlincourt et al.; IEEE Std 176).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from ..errors import Frozen, MaterialError, locked

__all__ = ["EPS0", "Piezoelectric", "Elastic", "Hencky", "hencky", "isotropic", "deviator", "PZT4", "PZT5A", "PZT5H", "BaTiO3", "hexagonal",
           "bond_matrix"]

EPS0 = 8.8541878128e-12
"""Vacuum permittivity, F/m."""


_PLANE = np.array([0, 2, 4])               # the 3D Voigt indices (xx, zz, xz) of the 2D strain (xx, yy, xy)
_PLANE_FIELD = np.array([0, 2])            # the 3D field components (x, z) of the 2D field (x, y)


class Piezoelectric(Frozen):
    """Piezoelectric material: its 3D tensors and their plane-strain reduction in the poling plane.

    Give either the hexagonal (6mm) constants ``c11, c13, c33, c44`` (Pa), ``e31, e33, e15`` (C/m^2),
    ``eps11, eps33`` (F/m) and ``c12`` (Pa; without it the material is 2D only), or use
    :meth:`from_matrices` for general 3D or plane constants. ``c``, ``e``, ``kappa``: the plane matrices;
    ``c3``, ``e3``, ``kappa3``: the 3D tensors (None for a 2D-only material); :meth:`tensors` gives those of a
    dimension. A material is immutable (read-only arrays; assigning an attribute raises
    :class:`~cvxcontact.errors.FrozenError`).
    """

    piezoelectric = True
    quadratic = True
    """The bulk energy is the quadratic form of c (:class:`Hencky`: not)."""

    def __init__(self, c11: float | None = None, c13: float | None = None, c33: float | None = None,
                 c44: float | None = None, e31: float | None = None, e33: float | None = None,
                 e15: float | None = None, eps11: float | None = None, eps33: float | None = None,
                 c12: float | None = None, name: str = "piezoelectric") -> None:
        given = dict(c11=c11, c13=c13, c33=c33, c44=c44, e31=e31, e33=e33, e15=e15, eps11=eps11, eps33=eps33)
        missing = [k for k, v in given.items() if v is None]
        if missing:
            raise MaterialError(f"material {name!r}: missing constant(s) {missing}")
        v = {k: _real(val, k, name) for k, val in given.items()}
        if c12 is None:                     # plane constants only: 2D
            c = [[v["c11"], v["c13"], 0.0], [v["c13"], v["c33"], 0.0], [0.0, 0.0, v["c44"]]]
            e = [[0.0, 0.0, v["e15"]], [v["e31"], v["e33"], 0.0]]
            kappa = [[v["eps11"], 0.0], [0.0, v["eps33"]]]
            self._setup(c, e, kappa, name, None)
            return
        c12 = _real(c12, "c12", name)
        if not (v["c11"] > abs(c12) and (v["c11"] + c12) * v["c33"] > 2 * v["c13"] ** 2):
            raise MaterialError(f"material {name!r}: the 3D elasticity tensor (c11, c12, c13, c33) "
                                "is not positive definite")
        self._setup(*hexagonal(v["c11"], c12, v["c13"], v["c33"], v["c44"], v["e31"], v["e33"], v["e15"],
                               v["eps11"], v["eps33"]), name, c12)

    @classmethod
    def from_matrices(cls, c: ArrayLike, e: ArrayLike, kappa: ArrayLike, name: str = "piezoelectric") -> Piezoelectric:
        """Material from 3D tensors, ``c`` (6, 6) Pa, ``e`` (3, 6) C/m^2, ``kappa`` (3, 3) F/m (Voigt order
        of the module docstring), or from plane matrices, ``c`` (3, 3), ``e`` (2, 3), ``kappa`` (2, 2)
        (then 2D only)."""
        obj = cls.__new__(cls)
        obj._setup(c, e, kappa, name, None)
        return obj

    def _setup(self, c, e, kappa, name, c12):
        c3 = e3 = k3 = None
        if np.shape(c) == (6, 6):
            c3 = _matrix(c, (6, 6), "c", name, spd=True)
            e3 = _matrix(e, (3, 6), "e", name, spd=False)
            k3 = _matrix(kappa, (3, 3), "kappa", name, spd=True)
            c, e, kappa = c3[np.ix_(_PLANE, _PLANE)], e3[np.ix_(_PLANE_FIELD, _PLANE)], k3[np.ix_(_PLANE_FIELD,
                                                                                                _PLANE_FIELD)]
        c = _matrix(c, (3, 3), "c", name, spd=True)
        e = _matrix(e, (2, 3), "e", name, spd=False)
        kappa = _matrix(kappa, (2, 2), "kappa", name, spd=True)
        self._set(c=c, e=e, kappa=kappa, c3=c3, e3=e3, kappa3=k3, name=str(name), c12=c12, plane="strain",
                  angle=0.0, rotation=_IDENTITY, out_of_plane=_out_of_plane(c3, e3))

    def _frozen_hint(self, name: str) -> str:
        return _MATERIAL_HINT

    def __repr__(self):
        return f"Piezoelectric({self.name!r})"

    def tensors(self, dim: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(c, e, kappa) of a body of dimension ``dim``: the 3D tensors (3) or the plane matrices (2)."""
        return _tensors(self, dim, (self.c, self.e, self.kappa), (self.c3, self.e3, self.kappa3))

    def rotated(self, rotation: float | ArrayLike) -> Piezoelectric:
        """The material turned by ``rotation``: a 3x3 rotation matrix R (its columns the turned axes; the
        poling axis points along R's last column; c' = M c M^T, e' = R e M^T, kappa' = R kappa R^T with M the
        Bond stress matrix of R, and the plane matrices the reduction of the turned tensors), or an angle
        (radians, counter-clockwise in the 2D model plane: c, e and kappa (and the out-of-plane row) rotated
        as plane tensors, the poling axis along (-sin angle, cos angle); the 3D tensors turned about the
        crystal's x2 axis accordingly). ``rotated(0)`` equals the material."""
        R = _rotation(rotation, self)
        if R is not None:
            c3, e3, k3 = _rotate3(R, self.c3, self.e3, self.kappa3)
            obj = Piezoelectric.from_matrices(c3, e3, k3, name=self.name)
            obj._set(c12=self.c12, angle=self.angle, rotation=locked(R @ self.rotation, float))
            return obj
        angle = _real(rotation, "angle", self.name)
        c, e, kappa, out = _rotate(self.c, self.e, self.kappa, self.out_of_plane, angle)
        obj = Piezoelectric.from_matrices(c, e, kappa, name=self.name)
        R = _plane_rotation(angle)
        c3, e3, k3 = _rotate3(R, self.c3, self.e3, self.kappa3) if self.c3 is not None else (None, None, None)
        obj._set(c12=self.c12, out_of_plane=_row(out), plane=self.plane, angle=self.angle + angle,
                 rotation=locked(R @ self.rotation, float), c3=_read_only(c3), e3=_read_only(e3),
                 kappa3=_read_only(k3))
        return obj

    def plane_stress(self) -> Piezoelectric:
        """The plane-stress reduction (sigma_zz = 0 through the thickness; the default is plane strain,
        eps_zz = 0), a 2D-only material. Needs the out-of-plane constants (``c12``): with a = C_z,plane,
        c22 = C_zz and b = e_plane,z, c' = c - a a^T / c22, e' = e - b a^T / c22, kappa' = kappa + b b^T / c22."""
        if self.plane == "stress":
            return self
        if self.out_of_plane is None:
            raise MaterialError(f"material {self.name!r}: plane stress needs the out-of-plane constant c12 "
                                "(give c12, or use a built-in material)")
        a, c22, b = self.out_of_plane
        obj = Piezoelectric.from_matrices(self.c - np.outer(a, a) / c22, self.e - np.outer(b, a) / c22,
                                          self.kappa + np.outer(b, b) / c22, name=self.name)
        obj._set(c12=self.c12, out_of_plane=self.out_of_plane, plane="stress", angle=self.angle,
                 rotation=self.rotation)
        return obj


class Elastic(Frozen):
    """Linear elastic material, ``c`` (6, 6) in Pa (3D, Voigt order of the module docstring; the plane
    matrix its (xx, zz, xz) block) or (3, 3) (plane strain only); carries no electric unknowns. Immutable,
    as :class:`Piezoelectric`."""

    piezoelectric = False
    quadratic = True
    """The bulk energy is the quadratic form of c (:class:`Hencky`: not)."""

    def __init__(self, c: ArrayLike, name: str = "elastic", E: float | None = None, nu: float | None = None) -> None:
        c3 = None
        if np.shape(c) == (6, 6):
            c3 = _matrix(c, (6, 6), "c", name, spd=True)
            c = c3[np.ix_(_PLANE, _PLANE)]
        out = _out_of_plane(c3, None)
        if out is None and E is not None and nu is not None:
            lam, mu = E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))
            out = _row((np.array([lam, lam, 0.0]), lam + 2 * mu, None))
        self._set(c=_matrix(c, (3, 3), "c", name, spd=True), c3=c3, name=str(name), E=E, nu=nu, plane="strain",
                  angle=0.0, rotation=_IDENTITY, out_of_plane=out)

    e = kappa = e3 = kappa3 = None

    def _frozen_hint(self, name: str) -> str:
        return _MATERIAL_HINT

    def __repr__(self):
        return f"Elastic({self.name!r})"

    def tensors(self, dim: int) -> tuple[np.ndarray, None, None]:
        """(c, None, None) of a body of dimension ``dim``: the 3D tensor (3) or the plane matrix (2)."""
        return _tensors(self, dim, (self.c, None, None), (self.c3, None, None))

    def rotated(self, rotation: float | ArrayLike) -> Elastic:
        """The material turned by ``rotation`` (a 3x3 rotation matrix, or an angle in radians in the 2D
        model plane; see :meth:`Piezoelectric.rotated`): c rotated as a tensor (an isotropic material is
        unchanged up to rounding)."""
        R = _rotation(rotation, self)
        if R is not None:
            obj = Elastic(_rotate3(R, self.c3)[0], name=self.name)
            obj._set(E=self.E, nu=self.nu, angle=self.angle, rotation=locked(R @ self.rotation, float))
            return obj
        angle = _real(rotation, "angle", self.name)
        c, _, _, out = _rotate(self.c, None, None, self.out_of_plane, angle)
        obj = Elastic(c, name=self.name)
        R = _plane_rotation(angle)
        obj._set(E=self.E, nu=self.nu, out_of_plane=_row(out), plane=self.plane, angle=self.angle + angle,
                 rotation=locked(R @ self.rotation, float),
                 c3=_read_only(_rotate3(R, self.c3)[0]) if self.c3 is not None else None)
        return obj

    def plane_stress(self) -> Elastic:
        """The plane-stress reduction c - a a^T / c22 (isotropic: E/(1-nu^2) [[1, nu, 0], [nu, 1, 0],
        [0, 0, (1-nu)/2]]), a 2D-only material; needs the out-of-plane constants (a material from
        :func:`isotropic`)."""
        if self.plane == "stress":
            return self
        if self.out_of_plane is None:
            raise MaterialError(f"material {self.name!r}: plane stress needs the out-of-plane constants; build "
                                "it with isotropic(E, nu)")
        a, c22, _ = self.out_of_plane
        obj = Elastic(self.c - np.outer(a, a) / c22, name=self.name)
        obj._set(E=self.E, nu=self.nu, out_of_plane=self.out_of_plane, plane="stress", angle=self.angle,
                 rotation=self.rotation)
        return obj


def deviator(dim: int) -> tuple[np.ndarray, np.ndarray]:
    """(P, t): the Voigt strain (engineering shears) of dimension ``dim`` -> a vector whose 2-norm is the Frobenius
    norm of the deviatoric strain (shear entries counted twice; in plane strain the zz entry -tr/3 kept), and
    the trace row t (tr eps = t . eps)."""
    normal = dim if dim == 3 else 2                 # the in-plane normal components (2D: xx, yy; zz = 0)
    t = np.zeros(3 if dim == 2 else 6)
    t[:normal] = 1.0
    rows = [np.eye(len(t))[i] - t / 3.0 for i in range(normal)]
    if dim == 2:
        rows.append(-t / 3.0)                       # eps_zz - tr/3 = -tr/3
    rows += [np.eye(len(t))[i] / np.sqrt(2.0) for i in range(normal, len(t))]   # sqrt(2) eps_ij = gamma_ij / sqrt(2)
    return np.array(rows), t


class Hencky(Elastic):
    """Hencky (deformation-theory) plasticity with linear hardening: an isotropic nonlinear elastic material whose
    stress is the gradient of the convex energy density (J/m^3; docs/materials.md, "Hencky")

        W(eps) = K/2 (tr eps)^2 + mu psi(s),   s = |dev eps|,   psi(s) = h s^2 + (1 - h) huber(s, s_y),

    huber(s, M) = s^2 (s <= M), 2 M s - M^2 beyond, s_y = sigma_y / (sqrt(6) mu): linear with shear modulus mu
    until the von Mises stress sqrt(3/2) |dev sigma| reaches ``sigma_y`` (Pa), then hardening with the deviatoric
    stiffness scaled by ``h`` (0 < h <= 1). A = grad W is strongly monotone (constant min(2 mu h, 3K)) and
    Lipschitz (max(2 mu, 3K)): the paper's assumptions on A. ``c``: the tangent at zero strain (that of
    ``isotropic(E, nu)``). Plane strain only in 2D (no plane-stress reduction)."""

    quadratic = False
    energy_constants = ("sigma_y", "h")
    """The constants of the energy beyond the tangent ``c``, which the geometry fingerprint reads
    (:mod:`cvxcontact.physics.fingerprint`): a prepared solver refuses a Hencky material with others."""

    def __init__(self, E: float, nu: float, sigma_y: float, h: float, name: str | None = None) -> None:
        lin = isotropic(E, nu)
        label = name or f"hencky(E={lin.E:g}, nu={lin.nu:g}, sigma_y={sigma_y:g}, h={h:g})" \
            if _isnum(sigma_y) and _isnum(h) else "hencky"
        sigma_y, h = _real(sigma_y, "sigma_y", label), _real(h, "h", label)
        if not (sigma_y > 0 and 0 < h <= 1):
            raise MaterialError(f"material {label!r}: need a finite yield stress sigma_y > 0 (Pa) and a "
                                f"hardening ratio 0 < h <= 1 (1: linear), got sigma_y={sigma_y!r}, h={h!r}")
        super().__init__(lin.c3, name=label, E=lin.E, nu=lin.nu)
        mu, K = lin.E / (2 * (1 + lin.nu)), lin.E / (3 * (1 - 2 * lin.nu))
        self._set(sigma_y=sigma_y, h=h, mu=mu, K=K, s_y=sigma_y / (np.sqrt(6.0) * mu))

    def __repr__(self):
        return f"Hencky({self.name!r})"

    def psi(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """psi(s) and psi'(s) of the class docstring (s >= 0)."""
        s = np.asarray(s, dtype=float)
        huber = np.where(s <= self.s_y, s ** 2, 2 * self.s_y * s - self.s_y ** 2)
        return (self.h * s ** 2 + (1 - self.h) * huber,
                2 * self.h * s + 2 * (1 - self.h) * np.minimum(s, self.s_y))

    def density(self, eps: np.ndarray, dim: int) -> np.ndarray:
        """W at the Voigt strains ``eps`` (..., 3 or 6), J/m^3."""
        P, t = deviator(dim)
        tr, s = eps @ t, np.linalg.norm(eps @ P.T, axis=-1)
        return 0.5 * self.K * tr ** 2 + self.mu * self.psi(s)[0]

    def stress(self, eps: np.ndarray, dim: int) -> np.ndarray:
        """sigma = A(eps) = K tr(eps) I + mu psi'(s) dev(eps) / s at the Voigt strains ``eps`` (..., 3 or 6): the
        Voigt stress (..., 3 or 6), Pa, the work conjugate of the engineering strains (in 2D the in-plane
        components; sigma_zz = K tr - mu psi'/s tr/3 is not returned)."""
        P, t = deviator(dim)
        d = eps @ P.T
        s = np.linalg.norm(d, axis=-1)
        ratio = np.where(s > 0, self.psi(s)[1] / np.where(s > 0, s, 1.0), 2.0)     # psi'(s)/s -> 2 at s = 0
        return self.K * (eps @ t)[..., None] * t + self.mu * (ratio[..., None] * d) @ P

    def tangent(self, eps: np.ndarray, dim: int, secant: bool = False) -> np.ndarray:
        """d sigma / d eps (..., s, s) at the Voigt strains ``eps``, Pa: K t t^T + mu P^T [psi'/s (I - n n^T) +
        psi'' n n^T] P, n = P eps / s (psi'/s and psi'' in [2 h, 2]). ``secant``: the secant stiffness instead,
        psi'' replaced by psi'/s, K t t^T + mu psi'/s P^T P (sigma = S(eps) eps; positive definite, at least the
        tangent; the Newton steps' start, :data:`~cvxcontact.backends.nonlinear.SECANT`). Below yield (s <= s_y,
        psi'/s = psi'' = 2) both are the tangent at zero strain K t t^T + 2 mu P^T P, written there as it is (the
        expression of the yielded points evaluated only at them)."""
        P, t = deviator(dim)
        eps = np.asarray(eps, dtype=float)
        d = eps @ P.T
        s = np.linalg.norm(d, axis=-1)
        C = np.empty(s.shape + (len(t), len(t)))
        C[...] = self.K * np.outer(t, t) + 2.0 * self.mu * (P.T @ P)
        yielded = s > self.s_y
        if yielded.any():
            d, s = d[yielded], s[yielded]
            ratio = self.psi(s)[1] / s
            second = ratio if secant else np.full_like(s, 2 * self.h)
            m = (d / s[:, None]) @ P                        # P^T n: P^T (I - n n^T) P = P^T P - m m^T
            C[yielded] = (self.K * np.outer(t, t) + (self.mu * ratio)[:, None, None] * (P.T @ P)
                          + (self.mu * (second - ratio))[:, None, None] * m[:, :, None] * m[:, None, :])
        return C

    def rotated(self, rotation):
        """The material itself: it is isotropic."""
        return self

    def plane_stress(self):
        raise MaterialError(f"material {self.name!r}: a Hencky material has no plane-stress reduction here; use "
                            "plane strain (the default) or a 3D body")


def hencky(E: float, nu: float, sigma_y: float, h: float, name: str | None = None) -> Hencky:
    """The :class:`Hencky` material (Young's modulus ``E`` and yield stress ``sigma_y`` in Pa, Poisson ratio
    ``nu``, hardening ratio ``h`` in (0, 1])."""
    return Hencky(E, nu, sigma_y, h, name)


_MATERIAL_HINT = ("build a new material (Piezoelectric(...), isotropic(E, nu), material.rotated(R or angle), "
                  "material.plane_stress()) and a body with body.with_changes(material=...)")


def hexagonal(c11, c12, c13, c33, c44, e31, e33, e15, eps11, eps33):
    """The 3D tensors (c (6, 6), e (3, 6), kappa (3, 3)) of a hexagonal (6mm) material poled along z
    (module docstring; c66 = (c11 - c12) / 2)."""
    c = np.zeros((6, 6))
    c[:3, :3] = [[c11, c12, c13], [c12, c11, c13], [c13, c13, c33]]
    c[3, 3] = c[4, 4] = c44
    c[5, 5] = 0.5 * (c11 - c12)
    e = np.zeros((3, 6))
    e[0, 4] = e[1, 3] = e15
    e[2, :3] = [e31, e31, e33]
    return c, e, np.diag([eps11, eps11, eps33])


def _tensors(mat, dim, plane, solid):
    if dim == 2:
        return plane
    if dim != 3:
        raise MaterialError(f"material {mat.name!r}: tensors(dim) takes dim 2 or 3, got {dim!r}")
    if solid[0] is None:
        why = ("is a plane-stress reduction (2D only)" if mat.plane == "stress" else
               "was given by its plane constants only: give c12 (Piezoelectric(..., c12=...)), 3D matrices "
               "(from_matrices with c (6, 6)), or use isotropic(E, nu) or a built-in material")
        raise MaterialError(f"material {mat.name!r} has no 3D constants: it {why}")
    return solid


def _out_of_plane(c3, e3):
    """The out-of-plane row (a, c22, b) of the plane reduction from the 3D tensors (crystal axis x2 = 3D y):
    a = c[yy, (xx, zz, xz)], c22 = c[yy, yy], b = e[(x, z), yy]; None without 3D tensors."""
    if c3 is None:
        return None
    return _row((c3[1, _PLANE], float(c3[1, 1]), None if e3 is None else e3[_PLANE_FIELD, 1]))


_IDENTITY = np.eye(3)
_IDENTITY.setflags(write=False)
_VOIGT = np.array([(0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1)])     # 3D Voigt pairs (xx, yy, zz, yz, xz, xy)


def bond_matrix(R) -> np.ndarray:
    """The 6x6 Bond stress matrix M of a rotation R (Auld, Acoustic Fields and Waves in Solids, vol. 1,
    ch. 3): sigma'_I = M_IJ sigma_J for sigma'_ij = R_ik R_jl sigma_kl in the Voigt order of the module
    docstring, M_IJ = (R_ik R_jl + R_il R_jk) / (1 + delta_kl) with I = (i, j), J = (k, l)."""
    R = np.asarray(R, dtype=float)
    i, j = _VOIGT[:, 0][:, None], _VOIGT[:, 1][:, None]
    k, l = _VOIGT[:, 0][None, :], _VOIGT[:, 1][None, :]
    return (R[i, k] * R[j, l] + R[i, l] * R[j, k]) / np.where(k == l, 2.0, 1.0)


def _rotate3(R, c, e=None, kappa=None):
    """The 3D tensors turned by R: c' = M c M^T, e' = R e M^T, kappa' = R kappa R^T (symmetrised)."""
    M = bond_matrix(R)
    c2 = M @ c @ M.T
    out = [0.5 * (c2 + c2.T)]
    if e is not None:
        k2 = R @ kappa @ R.T
        out += [R @ e @ M.T, 0.5 * (k2 + k2.T)]
    return tuple(out) + (None,) * (3 - len(out))


def _plane_rotation(angle):
    """The 3D rotation of a 2D rotation by ``angle`` in the model plane (x, y) = the crystal's (x, z)."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]])


def _rotation(rotation, mat):
    """A checked 3x3 rotation matrix, or None for a scalar angle."""
    if _isnum(rotation):
        return None
    try:
        R = np.array(rotation, dtype=float)
    except (TypeError, ValueError):
        R = None
    if R is None or R.shape != (3, 3) or not np.isfinite(R).all():
        raise MaterialError(f"material {mat.name!r}: rotated() takes a 3x3 rotation matrix or an angle in radians "
                            f"(2D), got {rotation!r}")
    dev = float(np.abs(R.T @ R - np.eye(3)).max())
    if dev > 1e-9 or np.linalg.det(R) < 0:
        raise MaterialError(f"material {mat.name!r}: rotated() needs a proper rotation matrix (R^T R = I, det R = +1); "
                            f"got |R^T R - I| = {dev:.3g}, det R = {np.linalg.det(R):.6g}")
    mat.tensors(3)                                   # a MaterialError naming why there are no 3D constants
    return R


def _read_only(a):
    return None if a is None else locked(a, float)


def _row(out):
    """The out-of-plane row (a, c22, b) with read-only arrays, or None."""
    if out is None:
        return None
    arrays = [None if v is None else locked(v, float) for v in (out[0], out[2])]
    return arrays[0], float(out[1]), arrays[1]


_PAIRS = ((0, 0), (1, 1), (0, 1))          # Voigt index of the plane: (11, 33, 13) of the crystal = (xx, yy, xy)


def _voigt(i, j):
    return i if i == j else 2


def _rotate(c, e, kappa, out, angle):
    """Rotate the plane matrices (c (3,3), e (2,3) or None, kappa (2,2) or None) and the out-of-plane row
    by ``angle`` (CCW) as tensors: c'_ijkl = Q_ip Q_jq Q_kr Q_ls c_pqrs etc."""
    Q = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    idx = np.array([[_voigt(i, j) for j in range(2)] for i in range(2)])
    ct = np.asarray(c)[idx[:, :, None, None], idx[None, None, :, :]]
    ct = np.einsum("ip,jq,kr,ls,pqrs->ijkl", Q, Q, Q, Q, ct)
    back = np.array(_PAIRS)
    c2 = ct[back[:, 0][:, None], back[:, 1][:, None], back[:, 0][None, :], back[:, 1][None, :]]
    c2 = 0.5 * (c2 + c2.T)
    e2 = k2 = None
    if e is not None:
        et = np.einsum("kp,iq,jr,pqr->kij", Q, Q, Q, np.asarray(e)[:, idx])
        e2 = et[:, back[:, 0], back[:, 1]]
        k2 = Q @ kappa @ Q.T
        k2 = 0.5 * (k2 + k2.T)
    if out is not None:
        a, c22, b = out
        at = Q @ np.asarray(a)[idx] @ Q.T
        out = (at[back[:, 0], back[:, 1]], c22, None if b is None else Q @ b)
    return c2, e2, k2, out


def isotropic(E: float, nu: float, name: str | None = None) -> Elastic:
    """Isotropic elastic material, Young's modulus ``E`` (Pa) and Poisson ratio ``nu``: the 3D tensor
    (lambda + 2 mu on the normal diagonal, lambda off it, mu on the shear diagonal) and its plane-strain
    reduction."""
    label = name or f"isotropic(E={E:g}, nu={nu:g})" if _isnum(E) and _isnum(nu) else "isotropic"
    E, nu = _real(E, "E", label), _real(nu, "nu", label)
    if E <= 0 or not -1.0 < nu < 0.5:
        raise MaterialError(f"material {label!r}: need E > 0 and -1 < nu < 0.5, got E={E!r}, nu={nu!r}")
    lam, mu = E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))
    c = np.zeros((6, 6))
    c[:3, :3] = lam
    c[[0, 1, 2], [0, 1, 2]] = lam + 2 * mu
    c[[3, 4, 5], [3, 4, 5]] = mu
    return Elastic(c, name=label, E=E, nu=nu)


def _isnum(v):
    return isinstance(v, (int, float, np.floating, np.integer)) and not isinstance(v, bool)


def _real(v, key, name):
    if not _isnum(v) or not np.isfinite(v):
        raise MaterialError(f"material {name!r}: constant {key} must be a finite number, got {v!r}")
    return float(v)


def _matrix(a, shape, key, name, spd):
    try:
        a = np.array(a, dtype=float)
    except (TypeError, ValueError):
        raise MaterialError(f"material {name!r}: {key} must be a numeric {shape} matrix") from None
    if a.shape != shape:
        raise MaterialError(f"material {name!r}: {key} must have shape {shape}, got {a.shape}")
    if not np.isfinite(a).all():
        raise MaterialError(f"material {name!r}: {key} has NaN or infinite entries")
    if spd:
        if not np.allclose(a, a.T, rtol=1e-12, atol=0.0):
            raise MaterialError(f"material {name!r}: {key} is not symmetric")
        lo = np.linalg.eigvalsh(a).min()
        if lo <= 1e-12 * np.abs(a).max():
            raise MaterialError(f"material {name!r}: {key} is not positive definite "
                                f"(smallest eigenvalue {lo:.3g})")
        a = 0.5 * (a + a.T)
    return locked(a)


def _table(name, c11, c12, c13, c33, c44, e31, e33, e15, eps11, eps33):
    """Build a material from the units of docs/materials.md §1: GPa, C/m^2, multiples of EPS0."""
    return Piezoelectric(c11=c11 * 1e9, c12=c12 * 1e9, c13=c13 * 1e9, c33=c33 * 1e9, c44=c44 * 1e9,
                         e31=e31, e33=e33, e15=e15, eps11=eps11 * EPS0, eps33=eps33 * EPS0, name=name)


PZT4 = _table("PZT-4", 139, 77.8, 74.3, 115, 25.6, -5.2, 15.1, 12.7, 730, 635)
PZT5A = _table("PZT-5A", 121, 75.4, 75.2, 111, 21.1, -5.4, 15.8, 12.3, 916, 830)
PZT5H = _table("PZT-5H", 126, 79.5, 84.1, 117, 23.0, -6.5, 23.3, 17.0, 1700, 1470)
BaTiO3 = _table("BaTiO3", 150, 66, 66, 146, 44, -4.35, 17.5, 11.4, 1115, 1260)
