"""What may change between solves of one ContactSolver: the loads.

A :class:`~cvxcontact.solve.ContactSolver` assembles, scales and (with the condensed backend)
factorises one geometry; it re-solves any scene whose bodies differ from the prepared ones
only in the fields below. This is the one definition of that split: the geometry fingerprint
(:mod:`cvxcontact.physics.fingerprint`) leaves out exactly these, and the sweep
(:mod:`cvxcontact.apps.sweep`) groups cases by everything else.

``LOAD_FIELDS``: attributes of a :class:`~cvxcontact.physics.body.Body` that are loads:
body force (N/m^3), tractions (N/m^2), surface charges (C/m^2), volume charge (C/m^3) and
the *values* of the driven electrode potentials (V) and of the floating electrodes' charges
(C/m). The *tags* of the driven and floating electrodes are geometry: they decide which
potential unknowns are free. Rollers and prescribed displacements (tags and values, m) are
geometry.

``SCENE_LOAD_FIELDS``: attributes of a :class:`~cvxcontact.physics.scene.Scene` that are
loads: the initial gap g (m) along Gamma_3.

``GEOMETRY_FIELDS``: the attributes of a Body a prepared solver depends on (in the
fingerprint). ``name`` is neither: it only labels messages.
"""

from __future__ import annotations

__all__ = ["LOAD_FIELDS", "SCENE_LOAD_FIELDS", "GEOMETRY_FIELDS", "LOAD_KEYS"]

LOAD_FIELDS: tuple[str, ...] = ("body_force", "traction", "surface_charge", "volume_charge", "potential",
                                 "floating")
"""Body attributes that may change between solves of one ContactSolver (``potential``, ``floating``: values
only)."""

SCENE_LOAD_FIELDS: tuple[str, ...] = ("gap",)
"""Scene attributes that may change between solves of one ContactSolver."""

GEOMETRY_FIELDS: tuple[str, ...] = ("mesh", "material", "clamped", "grounded", "contact", "roller", "displacement")
"""Body attributes a prepared solver depends on (with the tags, not the values, of ``potential``)."""

LOAD_KEYS: frozenset[str] = frozenset(LOAD_FIELDS + SCENE_LOAD_FIELDS)
"""Every key name (body or scene level) that names a load."""
