"""Derived fields of a solution, element by element: the values at each cell's centre (constant on each P1
triangle or tetrahedron), from the shape gradients there that the body's space gives
(:meth:`~cvxcontact.fem.space.Space.centre_gradients`).

Plane strain in the (x1, x3) plane, written x, y here; z is the out-of-plane x2:

    strain  (exx, eyy, 2 exy)           from u
    E = -grad(phi)                      V/m
    stress  sigma = c eps - e^T E       Pa, in plane; szz = c12 exx + c13 eyy - e31 Ey
            (elastic: szz = lambda (exx + eyy))
    D = e eps + kappa E                 C/m^2
    von Mises of (sxx, syy, szz, sxy)   Pa

In 3D (a tetrahedral body; constant on each P1 tetrahedron, at the centroid for P2) every field has all its
components: strain (exx, eyy, ezz, eyz, exz, exy) (tensor shears), stress (sxx, syy, szz, syz, sxz, sxy)
= c eps - e^T E with the 3D tensors, E and D (x, y, z), von Mises of the six stresses.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .assembly import voigt_strains

__all__ = ["BodyFields", "body_fields"]


@dataclass
class BodyFields:
    """Element fields of one body; arrays have one row per triangle."""

    strain: np.ndarray          # (m, 3): exx, eyy, exy (tensor shear), dimensionless; 3D (m, 6), module docstring
    stress: np.ndarray          # (m, 4): sxx, syy, szz, sxy, Pa; 3D (m, 6): sxx, syy, szz, syz, sxz, sxy
    von_mises: np.ndarray       # (m,), Pa
    electric_field: np.ndarray | None = None         # (m, dim), V/m
    electric_displacement: np.ndarray | None = None  # (m, dim), C/m^2


def body_fields(body, u, phi, nodes=None) -> BodyFields:
    """Strain, stress, von Mises stress, and for a piezoelectric body E and D, per cell (at its centre).

    ``nodes``: the node set of a degree-2 solution (:class:`~cvxcontact.geometry.quadratic.P2Nodes`,
    ``Q2Nodes``, ``P2TetNodes``; ``u``, ``phi`` on them), None for the mesh's vertices."""
    from .space import space_of

    mat = body.material
    el, grad = space_of(body, nodes).centre_gradients(body, nodes)
    if body.dim == 3:
        return _solid_fields(body, u, phi, el, grad)
    eps = voigt_strains(grad, np.asarray(u)[el])                 # (exx, eyy, 2exy)
    if not getattr(mat, "quadratic", True):     # a convex strain energy (Hencky): sigma = A(eps), not its c eps
        plane = np.zeros((len(eps), 6))         # plane strain: (exx, eyy, 0, 0, 0, 2exy); isotropic, so szz too
        plane[:, [0, 1, 5]] = eps
        s = mat.stress(plane, 3)[:, [0, 1, 2, 5]]
        strain = np.column_stack([eps[:, 0], eps[:, 1], 0.5 * eps[:, 2]])
        return BodyFields(strain=strain, stress=s, von_mises=_von_mises(s[:, :3], s[:, 3:]))
    stress = eps @ mat.c.T
    if mat.piezoelectric:
        field = -np.einsum("mij,mj->mi", grad, phi[el])
        stress -= field @ mat.e
        disp = eps @ mat.e.T + field @ mat.kappa.T
        c12 = mat.c12 if mat.c12 is not None else np.nan
        szz = c12 * eps[:, 0] + mat.c[0, 1] * eps[:, 1] - mat.e[1, 0] * field[:, 1]
    else:
        field = disp = None
        szz = mat.c[0, 1] * (eps[:, 0] + eps[:, 1])
    out = getattr(mat, "out_of_plane", None)
    if getattr(mat, "plane", "strain") == "stress":
        szz = np.zeros(len(eps))                                       # plane stress: sigma_zz = 0
    elif out is not None and (mat.angle != 0.0 or not np.array_equal(mat.rotation, np.eye(3))
                              or (mat.c12 if mat.piezoelectric else mat.E) is None):   # rotated or general: its row
        szz = eps @ out[0] - (field @ out[2] if field is not None else 0.0)
    s = np.column_stack([stress[:, 0], stress[:, 1], szz, stress[:, 2]])
    vm = _von_mises(s[:, :3], s[:, 3:])
    strain = np.column_stack([eps[:, 0], eps[:, 1], 0.5 * eps[:, 2]])
    return BodyFields(strain=strain, stress=s, von_mises=vm, electric_field=field, electric_displacement=disp)


def _solid_fields(body, u, phi, el, grad):
    """The fields of a 3D body (module docstring), per tetrahedron at its centroid (element nodes ``el``, shape
    gradients ``grad`` there)."""
    c, e, kappa = body.material.tensors(3)
    eps = voigt_strains(grad, np.asarray(u)[el])
    stress = eps @ c.T if getattr(body.material, "quadratic", True) else body.material.stress(eps, 3)
    field = disp = None
    if e is not None:
        field = -np.einsum("mij,mj->mi", grad, np.asarray(phi)[el])
        stress -= field @ e
        disp = eps @ e.T + field @ kappa.T
    vm = _von_mises(stress[:, :3], stress[:, 3:])
    strain = np.column_stack([eps[:, :3], 0.5 * eps[:, 3:]])
    return BodyFields(strain=strain, stress=stress, von_mises=vm, electric_field=field, electric_displacement=disp)


def _von_mises(normal: np.ndarray, shear: np.ndarray) -> np.ndarray:
    """The von Mises stress (Pa) of the normal stresses (m, 3) and the shear stresses (m, k), per cell."""
    s = normal
    return np.sqrt(0.5 * ((s[:, 0] - s[:, 1]) ** 2 + (s[:, 1] - s[:, 2]) ** 2 + (s[:, 2] - s[:, 0]) ** 2)
                   + 3.0 * (shear ** 2).sum(axis=1))
