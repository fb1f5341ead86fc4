"""A fingerprint of what a prepared solver depends on in a body: its geometry and material.

``geometry_fingerprint(body)`` hashes (SHA-256: with the processors' SHA instructions twice as fast as blake2b on
a large mesh, measured 34 against 62 ms per 32 MB) the mesh points (m) and triangles, every
tagged boundary part with its edges, the material constants c (Pa), e (C/m^2) and
kappa (F/m) (and a nonlinear energy's ``energy_constants``: Hencky's sigma_y (Pa) and h), and the names of the clamped, grounded, driven (potential) and contact
parts: the :data:`~cvxcontact.physics.loads.GEOMETRY_FIELDS` and the potential tags. The
loads (:data:`~cvxcontact.physics.loads.LOAD_FIELDS`: forces, tractions, charges, potential
*values*) are left out: they may change between solves of one ContactSolver. (The scene's
gap, :data:`~cvxcontact.physics.loads.SCENE_LOAD_FIELDS`, is not a body attribute.)
Two bodies with equal fingerprints assemble to the same matrices. Bodies, meshes and materials
are immutable (frozen attributes; arrays read-only for good, :func:`~cvxcontact.errors.locked`: no
``setflags(write=True)`` makes them writeable again), so a body's fingerprint is hashed once and kept on the body
(``_geometry_fingerprint``), and a body of the same geometry with other loads (``Body.with_loads``) starts with it:
a prepared solver's load case checks its bodies without hashing their meshes again (two_blocks(560): 10 ms a
load case).
"""

from __future__ import annotations

import hashlib

import numpy as np

__all__ = ["geometry_fingerprint"]


KEPT = "_geometry_fingerprint"
"""The attribute of a body that keeps its fingerprint (module docstring)."""


def geometry_fingerprint(body) -> str:
    """Hex digest over the mesh, boundary parts, material constants and part roles of ``body``: hashed on the
    first call and kept on the body (module docstring; an object without an instance dict is hashed every time)."""
    kept = getattr(body, "__dict__", {}).get(KEPT)
    if kept is not None:
        return kept
    digest = _digest(body)
    if hasattr(body, "__dict__"):
        object.__setattr__(body, KEPT, digest)          # (a frozen body: its attributes are set this way)
    return digest


def _digest(body) -> str:
    """The hash of :func:`geometry_fingerprint`, computed."""
    h = hashlib.sha256()

    def text(s):
        data = str(s).encode("utf-8")
        h.update(len(data).to_bytes(8, "little"))
        h.update(data)

    def array(name, a, dtype):
        text(name)
        if a is None:
            text("none")
            return
        a = np.ascontiguousarray(a, dtype=dtype)
        text(a.shape)
        h.update(a.reshape(-1).view(np.uint8))            # the array's bytes, not a copy of them (also of no bytes)

    mesh, mat = body.mesh, body.material
    array("points", mesh.points, np.float64)
    array("triangles", mesh.cells, np.int64)           # (the 2D name kept: fingerprints stay as they were)
    tags = sorted(mesh.tags)
    text(len(tags))
    for tag in tags:
        array(f"tag {tag}", mesh.boundary(tag), np.int64)
    text(type(mat).__name__)
    for key in ("c", "e", "kappa") + (("c3", "e3", "kappa3") if getattr(mesh, "dim", 2) == 3 else ()):
        array(key, getattr(mat, key, None), np.float64)
    for key in getattr(mat, "energy_constants", ()):   # a nonlinear energy's own constants (Hencky: sigma_y, h)
        array(key, getattr(mat, key), np.float64)
    # GEOMETRY_FIELDS beyond mesh and material, and the tags (not the values) of the driven electrodes
    for role, parts in (("clamped", body.clamped), ("grounded", body.grounded),
                        ("potential", list(body.potential)), ("contact", [] if body.contact is None else [body.contact]),
                        ("roller", getattr(body, "roller", [])), ("floating", list(getattr(body, "floating", {}))),
                        ("displacement", [f"{t}={v}" for t, v in getattr(body, "displacement", {}).items()])):
        parts = sorted(set(parts))
        text(role)
        text(len(parts))
        for p in parts:
            text(p)
    return h.hexdigest()
