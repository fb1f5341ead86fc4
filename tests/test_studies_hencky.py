"""The convergence study with a Hencky lower block (cvxcontact/apps/studies/convergence_hencky.py): its quick version
runs end to end, its plastic zone is the one the stresses show, its energy norm is the linear one and equivalent to
the nonlinear A's (the bound the study's docstring states, sampled).

Sanity bounds, wide on purpose (the study's outputs are measurements to read): they catch a broken study, not a
slow one.
"""

import csv

import numpy as np
import pytest

from cvxcontact import Route
from cvxcontact.apps.cli import main
from cvxcontact.apps.studies import convergence, convergence_hencky
from cvxcontact.errors import MaterialError
from cvxcontact.fem.fields import body_fields
from cvxcontact.physics import materials


def rows(path):
    with open(path) as fh:
        return list(csv.DictReader(fh))


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("convergence_hencky")
    assert main(["study", "convergence_hencky", "--quick", "--out", str(out), "-q"]) == 0
    return out


@pytest.mark.parametrize("dim", [2, 3])
def test_the_hencky_stress_lies_between_h_and_one_times_the_linear_tangent(dim):
    """For any two strains and d their difference, h d.C_0 d <= (A(eps_1) - A(eps_2)).d <= d.C_0 d, C_0 the isotropic
    material's tensor of the same E, nu (materials.isotropic, not the Hencky code): the energy norm of the linear
    tangent is equivalent to the nonlinear A's, the study's claim. Sampled on pairs below, across and beyond yield
    (|dev eps| up to 20 s_y) and on nearly equal pairs (the tangent's bounds); measured ratios in [0.1016, 1 + 9e-13]
    (2D) and [0.1040, 1 + 6e-13] (3D): the ends to rounding."""
    mat = convergence_hencky.HENCKY
    c = materials.isotropic(E=mat.E, nu=mat.nu).tensors(dim)[0]
    rng = np.random.default_rng(7)
    k = 3 if dim == 2 else 6
    scale = mat.s_y * rng.choice([0.3, 1.0, 3.0, 20.0], size=(4000, 1))
    e1 = rng.normal(size=(4000, k)) * scale
    e2 = np.where(rng.random((4000, 1)) < 0.5, e1 + 1e-3 * rng.normal(size=(4000, k)) * scale,
                  rng.normal(size=(4000, k)) * scale)
    d = e1 - e2
    work = np.einsum("qi,qi->q", mat.stress(e1, dim) - mat.stress(e2, dim), d)
    linear = np.einsum("qi,ij,qj->q", d, c, d)
    ratio = work / linear
    assert ratio.min() >= mat.h * (1 - 1e-9) and ratio.max() <= 1 + 1e-9, (ratio.min(), ratio.max())
    assert ratio.min() < mat.h + 0.05 and ratio.max() > 0.95          # both ends reached: the bound is sharp


@pytest.mark.numerics
def test_the_plastic_zone_is_where_the_von_mises_stress_passes_the_yield_stress():
    """P1 (one quadrature point per triangle, at which the strain is that of the cell): the yielded points counted
    from |dev eps| > s_y are the cells whose von Mises stress (fem.fields, from the stress) passes sigma_y
    (measured 10 of 42 at n = 8, "sigma1"); a block that never yields has none; an elastic body is refused, typed."""
    _, sol = convergence.level("smooth", 1, "sigma1", 8, "auto", convergence_hencky.HENCKY)
    zone = convergence_hencky.plastic_zone(sol)
    vm = body_fields(sol.scene.bodies[1], sol.u[1], None).von_mises
    assert zone["points"] == len(vm) and zone["yielded"] == int((vm > convergence_hencky.SIGMA_Y).sum())
    assert 0 < zone["yielded"] < zone["points"]
    never = materials.hencky(E=70e9, nu=0.3, sigma_y=1e15, h=0.1)
    _, sol = convergence.level("smooth", 1, "sigma1", 8, "auto", never)
    assert convergence_hencky.plastic_zone(sol)["yielded"] == 0
    with pytest.raises(MaterialError, match="quadratic energy"):
        convergence_hencky.plastic_zone(sol, body=0)


@pytest.mark.numerics
def test_the_reference_measures_in_the_linear_energy_norm():
    """The Hencky reference's matrices are those of the aluminium scene (the lower block's K is its tangent at zero
    strain), while its answer differs from the linear one (the block yields): the norm is the linear study's."""
    hencky = convergence.Reference("smooth", 8, 2, "sigma1", "auto", convergence_hencky.HENCKY)
    linear = convergence.Reference("smooth", 8, 2, "sigma1", "auto")
    for a, b in zip(hencky.mats, linear.mats):
        assert abs(a.Kuu - b.Kuu).max() <= 1e-14 * abs(b.Kuu).max()
    assert linear.errors(hencky.sol)["energy"] > 1e-2         # measured 0.094: the yielding is seen


@pytest.mark.numerics
def test_quick_study_writes_rates_and_plastic_zone(quick):
    """Quick version (P1 n = 4, 8, 16; P2 n = 4, 8; reference P2 "sigma1" n = 32): every level checked, a plastic zone
    at every level, nothing recorded as refused (P2 "gamma3" is solved since: docs/refusals.md row 35), energy
    rates above 0.4 (measured 0.56 to 1.32), P2 below P1 at the finest levels, and the reference's own error (n = 16
    against 32, measured 0.025) below the finest P2 error (measured 0.10 and 0.13)."""
    text = (quick / "convergence_hencky.md").read_text()
    assert text.startswith("# Convergence study with a nonlinear A")
    assert "## Refused" not in text and "UnsupportedError" not in text
    assert (quick / "convergence_hencky.png").read_bytes()[:4] == b"\x89PNG"
    err = rows(quick / "convergence_hencky.csv")
    assert {(r["degree"], r["condition"]) for r in err} == {(str(d), c) for d, c in convergence_hencky.CASES}
    assert all(r["ok"] == "True" and 0 < int(r["yielded"]) < int(r["points"]) for r in err), err
    rates = rows(quick / "convergence_hencky_rates.csv")
    assert len(rates) == 5 and min(float(r["rate_energy"]) for r in rates) > 0.4, rates
    finest = {d: min(float(r["energy"]) for r in err if r["degree"] == d) for d in ("1", "2")}
    assert finest["2"] < finest["1"]
    check = rows(quick / "convergence_hencky_reference.csv")
    assert len(check) == 1 and int(check[0]["n_check"]) * 2 == int(check[0]["n_ref"])
    assert 0 < float(check[0]["energy"]) < min(float(r["energy"]) for r in err if r["degree"] == "2")
    assert int(check[0]["yielded_ref"]) > 0


@pytest.mark.numerics
def test_the_fast_route_on_p2_nodal_rows_of_non_matching_meshes_is_the_linear_answer():
    """A Hencky block that never yields (sigma_y = 1e15 Pa) under P2 "sigma1" on the study's non-matching meshes
    (8 and 7 cells): ``auto``'s Newton route answers directly (NEWTON_DIRECT, sol.ok) with the linear study's
    answer (aluminium, the same E and nu, the condensed route) to rounding: measured 2.1e-15 (u), 7.3e-15 (phi),
    4.2e-15 (the pressure). Before, it returned NEWTON_DIRECT with equilibrium 0.11 (sol.ok False): its steps
    solved contact rows scrambled by an in-place sort (tests/test_newton_rows_order.py)."""
    never = materials.hencky(E=70e9, nu=0.3, sigma_y=1e15, h=0.1)
    _, sol = convergence.level("smooth", 2, "sigma1", 8, "auto", never)
    assert sol.ok and sol.info.route is Route.NEWTON_DIRECT, (sol.info.route, sol.residuals())
    _, linear = convergence.level("smooth", 2, "sigma1", 8)
    assert linear.ok and linear.info.method == "condensed"
    for a, b in [*zip(sol.u, linear.u), (sol.phi[0], linear.phi[0]), (sol.contact.pressure, linear.contact.pressure)]:
        assert np.abs(a - b).max() <= 1e-10 * np.abs(b).max()
