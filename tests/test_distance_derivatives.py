"""The gradient and Hessian of a rigid obstacle's posed distance along the contact part
(:meth:`cvxcontact.Rigid.distance_derivatives`, closed forms of :class:`~cvxcontact.physics.posings.ClosestPoint`
and :class:`~cvxcontact.physics.posings.Ray`), which the tangency Newton of P2 "gamma3" uses to find where the true
slack touches zero (docs/formulation.md §18). Independent reference: central differences (step 1e-5 m) of the
distance (the gradient) and of the gradient (the Hessian) along an orthonormal basis of the part's plane; the
Hessian's symmetry; the gradient's zero component along the part's normal."""

import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.contact.interface import canonical_tangent

R = 1.0
NU2 = [np.array([0.0, 1.0]), np.array([0.3, 1.0]) / np.hypot(0.3, 1.0)]
NU3 = np.array([0.1, -0.2, 1.0]) / np.linalg.norm([0.1, -0.2, 1.0])


def _profile(s):
    return s ** 2 / (2 * R) + 0.01 + 0.1 * s ** 3


def _height(x, y):
    return (x ** 2 + 2 * y ** 2) / (2 * R) + 0.1 * x ** 3


def _plane_basis(nu):
    return np.linalg.svd(np.eye(len(nu)) - np.outer(nu, nu))[0][:, :len(nu) - 1].T


def _cases():
    rng = np.random.default_rng(0)
    out = []
    for dist in ("closest", "ray"):
        for k, nu in enumerate(NU2):
            x = np.outer(rng.uniform(-0.4, 0.4, 20), canonical_tangent(nu))
            out.append((f"circle-{dist}-{k}", cc.Rigid.circle((0.1, 1.2), R, distance=dist), x, nu))
            out.append((f"profile-{dist}-{k}", cc.Rigid.profile(_profile, (0.05, 0.0), distance=dist), x, nu))
        x = rng.uniform(-0.3, 0.3, (20, 2)) @ _plane_basis(NU3)
        out.append((f"sphere-{dist}", cc.Rigid.sphere((0.05, -0.03, 0.6), 0.5, distance=dist), x, NU3))
        out.append((f"cylinder-{dist}", cc.Rigid.cylinder((0, 0, 0.6), (1, 0.2, 0.1), 0.5, distance=dist), x, NU3))
        out.append((f"height_field-{dist}", cc.Rigid.height_field(_height, (0, 0, 0.05), distance=dist), x, NU3))
        out.append((f"plane-{dist}", cc.Rigid.plane((0, 0, 0.1), (0.1, 0.05, -1), distance=dist), x, NU3))
    return out


@pytest.mark.parametrize("name, obstacle, x, nu", _cases(), ids=[c[0] for c in _cases()])
def test_the_distance_derivatives_match_central_differences(name, obstacle, x, nu):
    g, grad, hess = obstacle.distance_derivatives(x, nu)
    assert np.array_equal(g, obstacle.distance(x, nu))
    h = 1e-5
    grad_fd, hess_fd = np.zeros_like(grad), np.zeros_like(hess)
    for e in _plane_basis(nu):
        grad_fd += np.outer((obstacle.distance(x + h * e, nu) - obstacle.distance(x - h * e, nu)) / (2 * h), e)
        dG = obstacle.distance_derivatives(x + h * e, nu)[1] - obstacle.distance_derivatives(x - h * e, nu)[1]
        hess_fd += (dG / (2 * h))[:, :, None] * e[None, None, :]
    scale = np.abs(grad).max()
    assert np.abs(grad - grad_fd).max() < 1e-7 * scale               # measured <= 1.1e-9 (the differences' h^2)
    assert np.abs(grad @ nu).max() < 1e-15 * scale                    # along the part only
    H = max(np.abs(hess).max(), 1.0)                                  # 1/m; a plane's is 0
    assert np.abs(hess - hess_fd).max() < 5e-7 * H                    # measured <= 3.5e-9
    assert np.abs(hess - hess.transpose(0, 2, 1)).max() < 1e-14 * H   # measured <= 1e-16
    assert np.abs(hess @ nu).max() < 1e-14 * H


def test_a_sphere_closest_distance_hessian_is_the_sphere_through_the_point():
    # closed form: |x - c| - R has Hessian (I - n n^T) / |x - c|; on the plane z = 0 under the centre (0, 0, 0.6),
    # at the point below it: I_2 / 0.6 in x, y
    sphere = cc.Rigid.sphere((0, 0, 0.6), 0.5)
    g, grad, hess = sphere.distance_derivatives(np.zeros((1, 3)), np.array([0.0, 0.0, 1.0]))
    assert g[0] == pytest.approx(0.1, abs=1e-15) and np.all(grad == 0)
    assert np.allclose(hess[0], np.diag([1 / 0.6, 1 / 0.6, 0.0]), rtol=0, atol=1e-14)


def test_an_obstacle_given_by_its_distance_alone_gets_differences():
    # Rigid(kind, distance, describe): central differences of the distance; against the sphere's closed form
    c = np.array([0.05, -0.03, 0.6])
    given = cc.Rigid("ball", lambda x, nu: np.linalg.norm(x - c, axis=1) - 0.5, "ball()", dim=3)
    sphere = cc.Rigid.sphere(c, 0.5)
    x = np.random.default_rng(1).uniform(-0.3, 0.3, (10, 2)) @ _plane_basis(NU3)
    _, g1, h1 = given.distance_derivatives(x, NU3)
    _, g2, h2 = sphere.distance_derivatives(x, NU3)
    assert np.abs(g1 - g2).max() < 1e-6 and np.abs(h1 - h2).max() < 1e-5       # measured 1.1e-9, 7.3e-8
