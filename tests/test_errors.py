"""Bad scenes raise typed errors that name the offending item; none returns a solution."""

import numpy as np
import pytest

import cvxcontact as cc

PZT, ALU = cc.materials.PZT5A, cc.materials.isotropic(E=70e9, nu=0.33)


def upper(**kw):
    m = kw.pop("mesh", None) or cc.rectangle(x=(0, 1), y=(0, 0.5), nx=4, ny=2)
    args = dict(clamped=["top"], grounded=["top"], contact="bottom", body_force=(0, -1e9))
    args.update(kw)
    return cc.Body(m, args.pop("material", PZT), **args)


def lower(mesh=None, **kw):
    m = mesh or cc.rectangle(x=(0, 1), y=(-0.5, 0), nx=3, ny=2)
    args = dict(clamped=["bottom"], contact="top")
    args.update(kw)
    return cc.Body(m, ALU, **args)


@pytest.mark.parametrize("make,match", [
    (lambda: upper(grounded=[]), "without a grounded or driven electrode"),
    (lambda: upper(clamped=["roof"]), "unknown boundary tag 'roof'"),
    (lambda: upper(traction={"side": (0, 1)}), "unknown boundary tag 'side'"),
    (lambda: upper(body_force=(np.nan, 0.0)), "body_force: NaN"),
    (lambda: upper(body_force=(1.0, 2.0, 3.0)), "expected 2 components"),
    (lambda: upper(surface_charge={"left": np.inf}), r"surface_charge\['left'\]: NaN or infinite"),
    (lambda: upper(traction={"right": "up"}), "traction"),
    (lambda: upper(contact=["bottom"]), "one boundary tag"),
    (lambda: upper(clamped=["bottom"]), "'bottom' is both clamped and contact"),
    (lambda: upper(surface_charge={"top": 1e-3}), "'top' is both grounded and surface_charge"),
    (lambda: lower(grounded=["bottom"]), "carries no electric unknowns"),
    (lambda: cc.Body("mesh", PZT, clamped="top", contact="bottom"), "must be a cvxcontact.Mesh"),
    (lambda: cc.Body(cc.rectangle(), "PZT", clamped="top", contact="bottom"), "material must be"),
])
def test_bad_bodies(make, match):
    with pytest.raises(cc.SceneError, match=match):
        make()


@pytest.mark.parametrize("make,match", [
    (lambda: cc.Scene(upper(), lower(cc.rectangle(x=(0, 1), y=(-0.5, -0.01), nx=3, ny=2))), "not collinear"),
    (lambda: cc.Scene(upper(), lower(cc.rectangle(x=(1.2, 2.2), y=(-0.5, 0), nx=3, ny=2))), "do not overlap"),
    (lambda: cc.Scene(upper(), lower(cc.rectangle(x=(0, 1), y=(0.0, 0.3), nx=3, ny=2), contact="bottom",
                                     clamped="top")), "both bodies lie above"),
    (lambda: cc.Scene(upper(contact="left", clamped="right"), lower()), "do not face each other"),
    (lambda: cc.Scene(upper(), upper()), "both bodies lie above"),
    (lambda: (lambda b: cc.Scene(b, b))(upper()), "two distinct bodies"),
    (lambda: cc.Scene(upper(), "lower"), "argument 2"),
    (lambda: cc.Scene(upper(clamped=[]), lower()), r"nothing holds the rigid motion\(s\) \['translation x'\]"),
])
def test_bad_scenes(make, match):
    with pytest.raises(cc.SceneError, match=match):
        make()


def test_bent_contact_line_is_rejected():
    # issue 10 allows straight contact lines in any direction; a bent one (a kink at x = 0.5) is refused
    m = cc.rectangle(x=(0, 1), y=(0, 0.5), nx=4, ny=2)
    bent = cc.Mesh(m.points + np.column_stack([0 * m.points[:, 0], 0.1 * np.abs(m.points[:, 0] - 0.5)]),
                   m.triangles, {t: m.boundary(t) for t in m.tags})
    with pytest.raises(cc.SceneError, match="is not a straight segment"):
        cc.Scene(upper(mesh=bent), lower())


def test_callable_load_returning_nan_fails_at_solve_with_its_name():
    scene = cc.Scene(upper(body_force=lambda x, y: (0 * x, np.log(x - 0.5))), lower())
    with pytest.raises(cc.SceneError, match="body_force: the load function returned NaN"):
        with np.errstate(all="ignore"):
            cc.solve(scene)


def test_callable_load_of_wrong_shape():
    scene = cc.Scene(upper(volume_charge=lambda x, y: np.ones(7)), lower())
    with pytest.raises(cc.SceneError, match="volume_charge: the load function returned shape"):
        cc.solve(scene)


def test_bad_solve_arguments():
    scene = cc.Scene(upper(), lower())
    with pytest.raises(cc.SceneError, match="condition must be one of"):
        cc.solve(scene, condition="gamma4")
    with pytest.raises(cc.SolverError, match="not available"):
        cc.solve(scene, solver="NOSUCH")
    with pytest.raises(cc.SolverError, match="tol must be"):
        cc.solve(scene, tol=-1)
    with pytest.raises(cc.SceneError, match="takes a Scene"):
        cc.solve("scene")
    with pytest.raises(cc.SolverError, match="tol must be a finite positive number"):
        cc.solve(scene, tol=float("inf"))
    with pytest.raises(cc.SolverError, match="polish must be True or False"):
        cc.solve(scene, polish="no")
    with pytest.raises(cc.SolverError, match="solver option 'tol' is not a solver option; use the tol argument"):
        cc.solve(scene, solver_options={"tol": 1e-3})
    with pytest.raises(cc.SolverError, match="unknown Clarabel option 'warmstart'"):
        cc.solve(scene, solver_options={"warmstart": True})


def test_hierarchy():
    for e in (cc.MeshError, cc.MaterialError, cc.SceneError, cc.SolverError):
        assert issubclass(e, cc.CvxContactError)
    assert issubclass(cc.SceneError, ValueError) and issubclass(cc.SolverError, RuntimeError)
