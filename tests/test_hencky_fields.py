"""The stress a Hencky body reports (cell fields: plots, VTU output, ``body_fields``) is A(eps), the material's
nonlinear stress, not its tangent at zero times eps (found while writing the gallery's Hencky example: past yield
the fields were the linear material's). Checked on homogeneous uniaxial strains against the closed form written
from the energy's definition (docs/materials.md, "Hencky"), below and above yield, in 2D (plane strain) and 3D."""

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.fem.fields import body_fields

E, NU, SIGMA_Y, H = 70e9, 0.3, 200e6, 0.1


def closed_form(e):
    """(sxx, syy = szz, von Mises) of the uniaxial strain exx = e (others 0), Pa: tr = e, dev = e (2/3, -1/3,
    -1/3), s = |dev| = sqrt(2/3) |e|; sigma = K tr I + mu psi'(s)/s dev with psi'(s) = 2 H s + 2 (1 - H) min(s, s_y),
    s_y = sigma_y / (sqrt(6) mu); von Mises = |sxx - syy| = mu psi'(s)/s |e|."""
    mu, K = E / (2 * (1 + NU)), E / (3 * (1 - 2 * NU))
    s, s_y = np.sqrt(2 / 3) * abs(e), SIGMA_Y / (np.sqrt(6) * mu)
    ratio = (2 * H * s + 2 * (1 - H) * min(s, s_y)) / s
    return K * e + mu * ratio * 2 * e / 3, K * e - mu * ratio * e / 3, mu * ratio * abs(e)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("e", [1e-4, 6e-3, -8e-3], ids=["below yield", "above yield", "compressed above yield"])
def test_the_fields_of_a_hencky_body_are_its_nonlinear_stress(dim, e):
    mesh = (cc.rectangle(x=(0.0, 1.0), y=(0.0, 0.5), nx=4, ny=2) if dim == 2
            else cc.box(x=(0.0, 1.0), y=(0.0, 0.5), z=(0.0, 0.5), nx=2, ny=2, nz=2))
    body = cc.Body(mesh, cc.materials.hencky(E, NU, SIGMA_Y, H), clamped=["left"])
    u = np.zeros((len(mesh.points), dim))
    u[:, 0] = e * mesh.points[:, 0]
    fields = body_fields(body, u, None)
    sxx, syy, vm = closed_form(e)
    normal = fields.stress[:, :3]
    assert np.allclose(normal, [sxx, syy, syy], rtol=1e-12, atol=1e-12 * abs(sxx))   # measured ~1e-16
    assert np.allclose(fields.stress[:, 3:], 0.0, atol=1e-12 * abs(sxx))
    assert np.allclose(fields.von_mises, vm, rtol=1e-12)
    if abs(e) > 5e-3:                             # past yield (the linear von Mises 2 mu |e| > 320 MPa): below the linear material's (what was reported)
        linear = body_fields(cc.Body(mesh, cc.materials.isotropic(E, NU), clamped=["left"]), u, None)
        assert (fields.von_mises < 0.9 * linear.von_mises).all()
        assert np.allclose(fields.von_mises, vm, rtol=1e-12) and vm > SIGMA_Y
