"""Constitutive laws: piezoelectric (stress-charge form) and isotropic elastic, in plane strain (default)
or plane stress (``material.plane_stress()``), poling axis along +y or turned (``material.rotated(angle)``).

The 2D model plane is the crystal's (x1, x3) plane, poling axis x3 along +y.
Strain vector (eps11, eps33, 2 eps13), field vector (E1, E3) (docs/formulation.md §6,
docs/materials.md §3):

    sigma = c eps - e^T E,     D = e eps + kappa E,     E = -grad(phi)

    c = [[c11, c13, 0], [c13, c33, 0], [0, 0, c44]]     (Pa)
    e = [[0, 0, e15], [e31, e33, 0]]                     (C/m^2, rows D1, D3)
    kappa = diag(eps11, eps33)                           (F/m, clamped permittivities)

``c12`` enters only the out-of-plane stress sigma22 and is kept for output.
Built-in constants: ``docs/materials.md`` §1 (Berlincourt et al.; IEEE Std 176).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from ..errors import Frozen, MaterialError

__all__ = ["EPS0", "Piezoelectric", "Elastic", "isotropic", "PZT4", "PZT5A", "PZT5H", "BaTiO3"]

EPS0 = 8.8541878128e-12
"""Vacuum permittivity, F/m."""


class Piezoelectric(Frozen):
    """Piezoelectric material, plane-strain reduction in the poling plane.

    Give either the hexagonal (6mm) constants ``c11, c13, c33, c44`` (Pa),
    ``e31, e33, e15`` (C/m^2), ``eps11, eps33`` (F/m) and optionally ``c12`` (Pa), or
    use :meth:`from_matrices` for general plane constants. A material is immutable (read-only arrays;
    assigning an attribute raises :class:`~cvxcontact.errors.FrozenError`).
    """

    piezoelectric = True

    def __init__(self, c11: float | None = None, c13: float | None = None, c33: float | None = None,
                 c44: float | None = None, e31: float | None = None, e33: float | None = None,
                 e15: float | None = None, eps11: float | None = None, eps33: float | None = None,
                 c12: float | None = None, name: str = "piezoelectric") -> None:
        given = dict(c11=c11, c13=c13, c33=c33, c44=c44, e31=e31, e33=e33, e15=e15, eps11=eps11, eps33=eps33)
        missing = [k for k, v in given.items() if v is None]
        if missing:
            raise MaterialError(f"material {name!r}: missing constant(s) {missing}")
        v = {k: _real(val, k, name) for k, val in given.items()}
        c = [[v["c11"], v["c13"], 0.0], [v["c13"], v["c33"], 0.0], [0.0, 0.0, v["c44"]]]
        e = [[0.0, 0.0, v["e15"]], [v["e31"], v["e33"], 0.0]]
        kappa = [[v["eps11"], 0.0], [0.0, v["eps33"]]]
        if c12 is not None:
            c12 = _real(c12, "c12", name)
            if not (v["c11"] > abs(c12) and (v["c11"] + c12) * v["c33"] > 2 * v["c13"] ** 2):
                raise MaterialError(f"material {name!r}: the 3D elasticity tensor (c11, c12, c13, c33) "
                                    "is not positive definite")
        self._setup(c, e, kappa, name, c12)

    @classmethod
    def from_matrices(cls, c: ArrayLike, e: ArrayLike, kappa: ArrayLike, name: str = "piezoelectric") -> Piezoelectric:
        """Material from plane matrices: ``c`` (3, 3) Pa, ``e`` (2, 3) C/m^2, ``kappa`` (2, 2) F/m."""
        obj = cls.__new__(cls)
        obj._setup(c, e, kappa, name, None)
        return obj

    def _setup(self, c, e, kappa, name, c12):
        c = _matrix(c, (3, 3), "c", name, spd=True)
        e = _matrix(e, (2, 3), "e", name, spd=False)
        kappa = _matrix(kappa, (2, 2), "kappa", name, spd=True)
        # out-of-plane row (x2 of the crystal): sigma_zz = a . eps - b . E with C_zz = c22 (hexagonal: c11)
        hexagonal = c12 is not None and np.allclose(c[:2, 2], 0.0) and e[1, 2] == 0.0
        self._set(c=c, e=e, kappa=kappa, name=str(name), c12=c12, plane="strain", angle=0.0,
                  out_of_plane=_row((np.array([c12, c[0, 1], 0.0]), float(c[0, 0]), np.array([0.0, e[1, 0]]))
                                    if hexagonal else None))

    def _frozen_hint(self, name: str) -> str:
        return _MATERIAL_HINT

    def __repr__(self):
        return f"Piezoelectric({self.name!r})"

    def rotated(self, angle: float) -> Piezoelectric:
        """The material turned by ``angle`` (radians, counter-clockwise) in the model plane: c, e and
        kappa (and the out-of-plane row) rotated as tensors; the poling axis points along
        (-sin angle, cos angle). ``rotated(0)`` equals the material."""
        angle = _real(angle, "angle", self.name)
        c, e, kappa, out = _rotate(self.c, self.e, self.kappa, self.out_of_plane, angle)
        obj = Piezoelectric.from_matrices(c, e, kappa, name=self.name)
        obj._set(c12=self.c12, out_of_plane=_row(out), plane=self.plane, angle=self.angle + angle)
        return obj

    def plane_stress(self) -> Piezoelectric:
        """The plane-stress reduction (sigma_zz = 0 through the thickness; the default is plane strain,
        eps_zz = 0). Needs the out-of-plane constants (``c12``): with a = C_z,plane, c22 = C_zz and
        b = e_plane,z, c' = c - a a^T / c22, e' = e - b a^T / c22, kappa' = kappa + b b^T / c22."""
        if self.plane == "stress":
            return self
        if self.out_of_plane is None:
            raise MaterialError(f"material {self.name!r}: plane stress needs the out-of-plane constant c12 "
                                "(give c12, or use a built-in material)")
        a, c22, b = self.out_of_plane
        obj = Piezoelectric.from_matrices(self.c - np.outer(a, a) / c22, self.e - np.outer(b, a) / c22,
                                          self.kappa + np.outer(b, b) / c22, name=self.name)
        obj._set(c12=self.c12, out_of_plane=self.out_of_plane, plane="stress", angle=self.angle)
        return obj


class Elastic(Frozen):
    """Linear elastic material in plane strain, ``c`` (3, 3) in Pa; carries no electric unknowns.
    Immutable, as :class:`Piezoelectric`."""

    piezoelectric = False

    def __init__(self, c: ArrayLike, name: str = "elastic", E: float | None = None, nu: float | None = None) -> None:
        out = None
        if E is not None and nu is not None:
            lam, mu = E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))
            out = (np.array([lam, lam, 0.0]), lam + 2 * mu, None)
        self._set(c=_matrix(c, (3, 3), "c", name, spd=True), name=str(name), E=E, nu=nu, plane="strain", angle=0.0,
                  out_of_plane=_row(out))

    def _frozen_hint(self, name: str) -> str:
        return _MATERIAL_HINT

    def __repr__(self):
        return f"Elastic({self.name!r})"

    def rotated(self, angle: float) -> Elastic:
        """The material turned by ``angle`` (radians, counter-clockwise) in the model plane (c rotated as
        a tensor; an isotropic material is unchanged up to rounding)."""
        angle = _real(angle, "angle", self.name)
        c, _, _, out = _rotate(self.c, None, None, self.out_of_plane, angle)
        obj = Elastic(c, name=self.name)
        obj._set(E=self.E, nu=self.nu, out_of_plane=_row(out), plane=self.plane, angle=self.angle + angle)
        return obj

    def plane_stress(self) -> Elastic:
        """The plane-stress reduction c - a a^T / c22 (isotropic: E/(1-nu^2) [[1, nu, 0], [nu, 1, 0],
        [0, 0, (1-nu)/2]]); needs the out-of-plane constants (a material from :func:`isotropic`)."""
        if self.plane == "stress":
            return self
        if self.out_of_plane is None:
            raise MaterialError(f"material {self.name!r}: plane stress needs the out-of-plane constants; build "
                                "it with isotropic(E, nu)")
        a, c22, _ = self.out_of_plane
        obj = Elastic(self.c - np.outer(a, a) / c22, name=self.name)
        obj._set(E=self.E, nu=self.nu, out_of_plane=self.out_of_plane, plane="stress", angle=self.angle)
        return obj


_MATERIAL_HINT = ("build a new material (Piezoelectric(...), isotropic(E, nu), material.rotated(angle), "
                  "material.plane_stress()) and a body with body.with_changes(material=...)")


def _row(out):
    """The out-of-plane row (a, c22, b) with read-only arrays, or None."""
    if out is None:
        return None
    arrays = [None if v is None else np.array(v, dtype=float) for v in (out[0], out[2])]
    for a in arrays:
        if a is not None:
            a.setflags(write=False)
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
    """Isotropic elastic material, Young's modulus ``E`` (Pa) and Poisson ratio ``nu``, plane strain."""
    label = name or f"isotropic(E={E:g}, nu={nu:g})" if _isnum(E) and _isnum(nu) else "isotropic"
    E, nu = _real(E, "E", label), _real(nu, "nu", label)
    if E <= 0 or not -1.0 < nu < 0.5:
        raise MaterialError(f"material {label!r}: need E > 0 and -1 < nu < 0.5, got E={E!r}, nu={nu!r}")
    lam, mu = E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))
    c = [[lam + 2 * mu, lam, 0.0], [lam, lam + 2 * mu, 0.0], [0.0, 0.0, mu]]
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
    a.setflags(write=False)
    return a


def _table(name, c11, c12, c13, c33, c44, e31, e33, e15, eps11, eps33):
    """Build a material from the units of docs/materials.md §1: GPa, C/m^2, multiples of EPS0."""
    return Piezoelectric(c11=c11 * 1e9, c12=c12 * 1e9, c13=c13 * 1e9, c33=c33 * 1e9, c44=c44 * 1e9,
                         e31=e31, e33=e33, e15=e15, eps11=eps11 * EPS0, eps33=eps33 * EPS0, name=name)


PZT4 = _table("PZT-4", 139, 77.8, 74.3, 115, 25.6, -5.2, 15.1, 12.7, 730, 635)
PZT5A = _table("PZT-5A", 121, 75.4, 75.2, 111, 21.1, -5.4, 15.8, 12.3, 916, 830)
PZT5H = _table("PZT-5H", 126, 79.5, 84.1, 117, 23.0, -6.5, 23.3, 17.0, 1700, 1470)
BaTiO3 = _table("BaTiO3", 150, 66, 66, 146, 44, -4.35, 17.5, 11.4, 1115, 1260)
