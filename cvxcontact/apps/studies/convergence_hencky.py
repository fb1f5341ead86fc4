"""Convergence study with the paper's nonlinear A: the rates of Theorems 1-3 with a Hencky lower block.

The scene is the convergence study's "smooth" one (:func:`~cvxcontact.apps.studies.convergence.scene`: PZT-5A on
a block, roller sides, the parabolic gap closing on an interior zone), its lower block now the Hencky material of
:data:`HENCKY` (deformation-theory plasticity with linear hardening, docs/materials.md §8: E = 70 GPa,
nu = 0.3 as the aluminium of the linear study, yield stress :data:`SIGMA_Y`, hardening ratio 0.1), which yields
under the contact zone at every level; the upper PZT-5A body is unchanged (the paper: A nonlinear, E and B
linear). Levels, errors and rates are those of :mod:`~cvxcontact.apps.studies.convergence` (its machinery, with
the material and the route as arguments):

* P1 "gamma3", "sigma1", "sigma2" at n = 8 ... 128 and P2 "sigma1", "sigma2" at n = 4 ... 64, by ``auto`` (the
  Newton route of docs/formulation.md §19; where its steps do not settle, the interior point with the Newton
  finish answers: the column ``route``). P2 "gamma3" (the conic condition) with a Hencky body, solved since by the
  full route (docs/refusals.md row 35, tests/test_p2_cones_hencky.py), is not measured here yet: its rows join
  :data:`CASES` with the committed tables regenerated.
* The reference (:data:`REFERENCE`): P2 "sigma1" on matching meshes, n = 256 (32 in the quick version). On
  matching meshes the nodal conditions "sigma1" and "sigma2" coincide and the P2 nodal condition is the one the
  package solves with a Hencky body; P2 is a higher order than either degree it is compared with. Unlike the
  linear study's conic reference it is not conforming between the nodes (a P2 jump can pass the gap between two
  nodes; on the matching level P2 n = 4 the largest penetration measured is 1.4e-17 m, rounding); its own error is
  measured as the linear smooth study's:
  the reference at half its n against it (``convergence_hencky_reference.csv``).
* The energy norm is that of the linear study, e^T K e with the reference's matrices, K of the lower block its
  tangent at zero strain (the aluminium's). It is equivalent to the norm the theorems' proofs use with a
  nonlinear A: with psi'' in [2 h, 2] the Hencky stress satisfies, for any two strains and d their difference,
  h d^T C_0 d <= (A(eps_1) - A(eps_2)) . d <= d^T C_0 d (C_0 the tangent at zero strain; strongly monotone and
  Lipschitz, the paper's assumptions), so the two norms of an error differ by at most the factor 1 / sqrt(h)
  and the rates are the same (tests/test_studies_hencky.py samples the bound).

The plastic zone of every level is recorded: the quadrature points of the lower block (those of its bulk energy)
whose deviatoric strain exceeds s_y (``yielded`` of ``points``; ``yielded_area``: their share of the block's
area by the quadrature weights). Outputs ``convergence_hencky.*`` (CSV of the errors, of the rates, of the
reference's own error; the figure; the Markdown summary).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...errors import CvxContactError, MaterialError
from ...fem.space import space
from ...physics import materials
from ...physics.materials import deviator
from . import convergence
from .common import markdown_table, write_csv, write_text

SIGMA_Y = 3e9
"""The lower block's yield stress (Pa): about 70 % of the largest von Mises stress of the linear answer (4.3 GPa:
the 0.05 m interference on a 1 m block is a large load, and a yield stress of its size keeps the ratio of an
indented aluminium block), so that a plastic zone forms under the contact zone at every level, P1 n = 8 included,
and stays a zone: about a fifth of the block's area (measured: 10 of 42 points at P1 n = 8, 22 % of the area at
n = 64; 1.5 GPa yields two thirds of the block, 2.5 GPa a third)."""

HENCKY = materials.hencky(E=70e9, nu=0.3, sigma_y=SIGMA_Y, h=0.1, name="aluminium (Hencky)")
"""The lower block: Hencky plasticity with linear hardening, the elastic constants of the linear study's aluminium."""

CASES = ((1, "gamma3"), (1, "sigma1"), (1, "sigma2"), (2, "sigma1"), (2, "sigma2"))
"""The (degree, condition) pairs measured (P2 "gamma3" not yet: the module docstring)."""

REFUSED: tuple = ()
"""The (degree, condition) pairs the package refuses with a Hencky body: tried once, their message recorded (none
since P2 "gamma3" is solved, docs/refusals.md row 35)."""

REFERENCE = (2, "sigma1")
"""The reference's (degree, condition), on matching meshes."""

SCENE = "smooth"
"""The convergence study's scene whose lower block is made Hencky."""

METHOD = "auto"
"""The route of every solve: the Newton route for a Hencky body (the condensed route refuses a non-quadratic
energy)."""


def plastic_zone(sol, body: int = 1) -> dict:
    """The yielded quadrature points of ``sol``'s body ``body`` (a Hencky material): ``yielded`` (points whose
    deviatoric strain |dev eps| exceeds the material's s_y), ``points`` (all points of its bulk energy) and
    ``yielded_area`` (the yielded points' share of the body's area, by the quadrature weights)."""
    b = sol.scene.bodies[body]
    element = space(sol.degree, b.mesh.cell)
    system = element.assemble_matrices(b, element.nodes(b))
    if system.strain is None:
        raise MaterialError(f"body {body} of the scene has a quadratic energy (material {b.material.name!r}): "
                              "no plastic zone to count; give it a Hencky material (materials.hencky)")
    eps = (system.strain @ np.asarray(sol.u[body]).ravel()).reshape(len(system.weights), -1)
    s = np.linalg.norm(eps @ deviator(b.mesh.dim)[0].T, axis=1)
    yielded = s > b.material.s_y
    return {"yielded": int(yielded.sum()), "points": len(s),
            "yielded_area": float(system.weights[yielded].sum() / system.weights.sum())}


def _columns(sol) -> dict:
    """The columns a level's row adds to the linear study's: the route and the plastic zone."""
    return {"route": str(getattr(sol.info.route, "name", sol.info.route)), **plastic_zone(sol)}


def refusals(kind: str = SCENE, n: int = 4) -> list[dict]:
    """Each pair of :data:`REFUSED` solved once on the coarsest mesh: the refusal's error type and message (or,
    should the package take it one day, ``"solved"``)."""
    out = []
    for degree, condition in REFUSED:
        try:
            convergence.level(kind, degree, condition, n, METHOD, HENCKY)
            answer = {"error": "solved", "message": "no longer refused: add it to CASES"}
        except CvxContactError as exc:
            answer = {"error": type(exc).__name__, "message": str(exc)}
        out.append({"degree": degree, "condition": condition, **answer})
    return out


def run(out, quick=False, progress=None):
    """Run the study and write ``convergence_hencky.*`` into ``out`` (module docstring). Full version: P1 n = 8 ...
    128, P2 n = 4 ... 64, the reference P2 "sigma1" n = 256 checked against n = 128; quick version: P1 n = 4, 8,
    16, P2 n = 4, 8, the reference n = 32 (check: 16). Returns ``{"rows", "rates", "reference_check",
    "refused"}``."""
    say = progress or (lambda s: None)
    out = Path(out)
    levels = {1: [4, 8, 16], 2: [4, 8]} if quick else {1: [8, 16, 32, 64, 128], 2: [4, 8, 16, 32, 64]}
    n_ref = 32 if quick else 256
    refused = refusals()
    for r in refused:
        say(f"convergence_hencky: P{r['degree']} {r['condition']} with a Hencky body: {r['error']}")
    rows, rates, checks = convergence.measure_rates([SCENE], levels, n_ref, say, check_reference=True, cases=CASES,
                                               reference=REFERENCE, method=METHOD, material=HENCKY, extra=_columns)
    _write(out, rows, rates, checks, refused, levels, n_ref)
    return {"rows": rows, "rates": rates, "reference_check": checks, "refused": refused}


def _write(out, rows, rates, checks, refused, levels, n_ref):
    stem = "convergence_hencky"
    write_csv(out / f"{stem}.csv", rows)
    write_csv(out / f"{stem}_rates.csv", rates)
    write_csv(out / f"{stem}_reference.csv", checks)
    convergence.rates_figure(rows, rates, out / f"{stem}.png", [SCENE])
    e3 = {k: ".3e" for k in ("energy", "lam_l2", "lam_h12", "traction_l2")}
    f2 = {k: ".2f" for k in ("rate_energy", "last_energy", "rate_lam_l2", "rate_lam_h12", "last_lam_h12",
                             "rate_traction_l2")}
    m = HENCKY
    text = (
        "# Convergence study with a nonlinear A (Hencky lower block)\n\n"
        f"The convergence study's \"smooth\" scene (roller sides) with its lower block the Hencky material "
        f"E = {m.E:g} Pa, nu = {m.nu:g}, sigma_y = {m.sigma_y:g} Pa, h = {m.h:g} (docs/materials.md §8; the "
        "elastic constants of the linear study's aluminium); the upper PZT-5A body unchanged (A nonlinear, E and B "
        "linear). Every solve by `auto` (the Newton route; `route`: NEWTON_FELL_BACK where its steps did not "
        "settle and the interior point with the Newton finish answered). Errors against a reference solved with "
        f"P2 \"sigma1\" on matching meshes (n = {n_ref} cells on Gamma_3; P2 \"gamma3\" is not measured here). "
        "P1 levels n = " + ", ".join(map(str, levels[1])) + ", P2 levels n = "
        + ", ".join(map(str, levels[2])) + ", lower mesh n2 = 3n/4 + 1 cells (non-matching). Rates are "
        "least-squares slopes over all levels; `last_*` the slope between the two finest levels. Theorem rates "
        "for the energy error with eta at the degree's cap: Th. 1 h^{1/2+eta}, Th. 2 h^{1/2+eta/2}, Th. 3 "
        "h^{1/2+eta}. The energy norm is the linear study's, with the lower block's tangent at zero strain C_0: "
        "equivalent to the norm of the nonlinear A, since h d.C_0 d <= (A(eps_1) - A(eps_2)).d <= d.C_0 d "
        "(strongly monotone and Lipschitz), so the two differ by at most 1/sqrt(h) and give the same rates. "
        "Compare with the linear material: `convergence_smooth.md`.\n\n"
        + ("## Refused\n\n" + markdown_table(refused, ["degree", "condition", "error", "message"]) + "\n"
           if refused else "")
        + "## The reference's own error\n\nThe reference at half its n measured against the reference, same "
        "norms (an upper estimate of the reference's own error), and the reference's plastic zone:\n\n"
        + markdown_table(checks, ["scene", "n_check", "n_ref", "energy", "lam_l2", "lam_h12", "traction_l2",
                                  "checks_max", "yielded_ref", "points_ref", "yielded_area_ref"],
                         e3 | {"checks_max": ".1e", "yielded_area_ref": ".3f"})
        + "\n## Observed rates\n\n"
        + markdown_table(rates, ["degree", "condition", "theorem", "theorem_rate", "rate_energy", "last_energy",
                                 "rate_lam_l2", "rate_lam_h12", "last_lam_h12", "rate_traction_l2"], f2)
        + "\n## Errors and plastic zone\n\n"
        + markdown_table(rows, ["degree", "condition", "n1", "n2", "dofs", "energy", "lam_l2", "lam_h12",
                                "traction_l2", "penetration", "active", "yielded", "points", "yielded_area", "route",
                                "checks_max", "seconds"],
                         e3 | {"penetration": ".2e", "checks_max": ".1e", "seconds": ".2f", "yielded_area": ".3f"}))
    write_text(out / f"{stem}.md", text)

