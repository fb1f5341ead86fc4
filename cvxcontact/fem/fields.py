"""Derived fields of a solution, element by element (constant on each P1 triangle; for P2, the values
at each triangle's centroid).

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

from .assembly import gradients, strain_matrix
from .p2 import strain_p2, shape_gradients

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
    """Strain, stress, von Mises stress, and for a piezoelectric body E and D, per triangle.

    ``nodes``: the :class:`~cvxcontact.geometry.quadratic.P2Nodes` of a P2 solution (``u``, ``phi`` on
    them); the fields are then evaluated at each triangle's centroid."""
    mesh, mat = body.mesh, body.material
    if body.dim == 3:
        return _solid_fields(body, u, phi, nodes)
    _, grad = gradients(mesh.points, mesh.triangles)
    if nodes is None:
        el = mesh.triangles
        ue = u[el].reshape(len(el), 6)
        eps = np.einsum("mij,mj->mi", strain_matrix(grad), ue)          # (exx, eyy, 2exy)
    else:
        el = nodes.triangles
        grad = shape_gradients(grad, np.full(3, 1.0 / 3.0))             # (m, 2, 6) at the centroid
        eps = np.einsum("mij,mj->mi", strain_p2(grad), u[el].reshape(len(el), 12))
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
    vm = np.sqrt(0.5 * ((s[:, 0] - s[:, 1]) ** 2 + (s[:, 1] - s[:, 2]) ** 2 + (s[:, 2] - s[:, 0]) ** 2)
                 + 3.0 * s[:, 3] ** 2)
    strain = np.column_stack([eps[:, 0], eps[:, 1], 0.5 * eps[:, 2]])
    return BodyFields(strain=strain, stress=s, von_mises=vm, electric_field=field, electric_displacement=disp)


def _solid_fields(body, u, phi, nodes):
    """The fields of a 3D body (module docstring), per tetrahedron (P2: at its centroid)."""
    mesh = body.mesh
    c, e, kappa = body.material.tensors(3)
    _, grad = gradients(mesh.points, mesh.cells)
    el = mesh.cells if nodes is None else nodes.cells
    if nodes is not None:
        grad = shape_gradients(grad, np.full(4, 0.25))                   # (m, 3, 10) at the centroid
    eps = np.einsum("mij,mj->mi", strain_matrix(grad), np.asarray(u)[el].reshape(len(el), -1))
    stress = eps @ c.T
    field = disp = None
    if e is not None:
        field = -np.einsum("mij,mj->mi", grad, np.asarray(phi)[el])
        stress -= field @ e
        disp = eps @ e.T + field @ kappa.T
    s = stress
    vm = np.sqrt(0.5 * ((s[:, 0] - s[:, 1]) ** 2 + (s[:, 1] - s[:, 2]) ** 2 + (s[:, 2] - s[:, 0]) ** 2)
                 + 3.0 * (s[:, 3:] ** 2).sum(axis=1))
    strain = np.column_stack([eps[:, :3], 0.5 * eps[:, 3:]])
    return BodyFields(strain=strain, stress=stress, von_mises=vm, electric_field=field, electric_displacement=disp)
