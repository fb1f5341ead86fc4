"""cc.adapt: the loop solve -> estimate -> mark -> refine, its marking, stops and refusals; adaptive against
uniform refinement on Hertz's cylinder (the study cvxcontact.apps.studies.adapt, docs/accuracy.md)."""

import warnings

import numpy as np
import pytest
from obstacle_scenes import indented_block

import cvxcontact as cc
from cvxcontact.adapt import mark_bulk
from cvxcontact.apps.studies.adapt import coarse_scene, measures
from cvxcontact.geometry.refine import refine_uniform


def uniformly(scene, times):
    return scene.with_bodies(*(b.with_changes(mesh=refine_uniform(b.mesh, times)[0]) for b in scene.bodies))


def test_adapt_reduces_the_estimate_and_beats_uniform():
    """10 steps from 32 cells cut the estimate by a factor > 2 (measured 3.25: 1611 -> 496 at 254 cells), below
    that of the uniform mesh with twice the cells (512 cells: 779; measured ratio 0.64)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        result = cc.adapt(indented_block(), theta=0.5, max_steps=10)
        uniform = cc.solve(uniformly(indented_block(), 2))
    h = result.history
    assert result.stopped == "max_steps" and len(h) == 11 and [s.step for s in h] == list(range(11))
    assert all(b.cells > a.cells for a, b in zip(h, h[1:]))
    assert h[-1].marked == 0 and all(s.marked > 0 for s in h[:-1]) and all(s.ok for s in h)
    assert result.solution.scene is result.scene
    assert result.solution.estimate.absolute == h[-1].estimate
    assert h[0].estimate / h[-1].estimate > 2.0
    assert 2 * h[-1].cells <= len(uniform.scene.bodies[0].mesh.triangles)
    assert h[-1].estimate < 0.8 * uniform.estimate.absolute


@pytest.mark.parametrize("degree, level, ratio", [(1, 2, 11), (2, 1, 6.8)])
def test_adaptive_peak_pressure_closer_to_hertz(degree, level, ratio):
    """On Hertz's cylinder (the study's scene, non-matching sides refined each on its own), the adaptive mesh
    with no more unknowns than the uniform one at ``level`` has a peak pressure closer to Hertz's closed form by
    more than a factor 3 (measured ``ratio``: P1 1194 unknowns +2.7e-2 against 1876 +3.0e-1; P2 1764, +1.2e-2
    against 1876, +7.9e-2)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        uniform = measures(cc.solve(uniformly(coarse_scene(), level), method="condensed", degree=degree))
        cells = uniform["unknowns"] if degree == 1 else uniform["unknowns"] // 4
        result = cc.adapt(coarse_scene(), method="condensed", degree=degree, theta=0.5, rate=np.inf,
                          exact_steps=True, max_steps=40,
                          max_cells=cells)    # the loop measured (P2's default: LOOPS)
        adaptive = measures(result.solution)
    assert result.stopped == "max_cells"
    assert adaptive["unknowns"] <= uniform["unknowns"]
    sizes = [len(b.mesh.triangles) for b in result.scene.bodies]
    assert sizes[0] != sizes[1]
    assert abs(adaptive["p0_rel_error"]) < abs(uniform["p0_rel_error"]) / 3


def test_mark_bulk_is_the_smallest_bulk():
    """Against a brute-force count: the fewest cells whose squared indicators reach theta of the total, over
    several bodies together; theta = 1 marks every non-zero cell; all zero marks none."""
    rng = np.random.default_rng(5)
    eta = [rng.random(7), rng.random(11) * 3, rng.random(4)]
    flat = np.sort(np.concatenate(eta) ** 2)[::-1]
    for theta in (0.1, 0.3, 0.5, 0.9):
        masks = mark_bulk(eta, theta)
        k = int(np.argmax(np.cumsum(flat) >= theta * flat.sum())) + 1
        assert sum(int(m.sum()) for m in masks) == k
        assert sum((e[m] ** 2).sum() for e, m in zip(eta, masks)) >= theta * flat.sum()
        assert [len(m) for m in masks] == [7, 11, 4]
    masks = mark_bulk([np.array([0.0, 1.0, 2.0])], 1.0)
    assert masks[0].tolist() == [False, True, True]
    assert not mark_bulk([np.zeros(3)], 0.5)[0].any()


def test_stops():
    """tol reached at the first solve; max_cells below the first refinement; max_steps=0: one solve each."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        assert cc.adapt(indented_block(), tol=100.0).stopped == "tol"
        r = cc.adapt(indented_block(), max_cells=33)
        assert r.stopped == "max_cells" and len(r.history) == 1 and r.history[0].marked == 0
        r = cc.adapt(indented_block(), max_steps=0, keep=True)
        assert r.stopped == "max_steps" and len(r.solutions) == 1


def test_refusals():
    scene = indented_block()
    with pytest.raises(cc.SceneError, match="takes a cc.Scene"):
        cc.adapt(scene.bodies[0])
    for bad in (0, 1.5, "half", True):
        with pytest.raises(cc.SceneError, match="theta"):
            cc.adapt(scene, theta=bad)
    with pytest.raises(cc.SceneError, match="estimate=False"):
        cc.adapt(scene, estimate=False)
    with pytest.raises(cc.SceneError, match="max_steps"):
        cc.adapt(scene, max_steps=-1)
    with pytest.raises(cc.SceneError, match="tol"):
        cc.adapt(scene, tol=0.0)
    with pytest.raises(cc.SceneError, match="curves names body 'cylinder'"):
        cc.adapt(scene, curves={"cylinder": {}})
    assert callable(cc.adapt) and cc.adapt.__module__ == "cvxcontact.adapt"


def test_the_committed_adapt_table_is_what_its_study_computes():
    """docs/studies/adapt/adapt.csv's first P1 adaptive steps (0-8) against a fresh run of the loop: cells, unknowns
    and estimate (rel 1e-6: the condensed P1 route's finish gives them to rounding), and every row docs/accuracy.md
    quotes is a row of the generated adapt.md. Regenerate with `cvxcontact study adapt --out docs/studies/adapt`."""
    import csv
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    with open(root / "docs" / "studies" / "adapt" / "adapt.csv") as fh:
        committed = [r for r in csv.DictReader(fh) if r["refinement"] == "adaptive" and r["degree"] == "1"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        fresh = cc.adapt(coarse_scene(), method="condensed", theta=0.5, max_steps=8).history
    for old, new in zip(committed, fresh):
        assert (int(old["cells"]), int(old["unknowns"])) == (new.cells, new.unknowns)
        assert float(old["estimate"]) == pytest.approx(new.estimate, rel=1e-6)
    table = (root / "docs" / "studies" / "adapt" / "adapt.md").read_text()
    quoted = [line for line in (root / "docs" / "accuracy.md").read_text().splitlines()
              if line.startswith(("| uniform |", "| adaptive |"))]
    assert len(quoted) == 8 and all(line in table for line in quoted)
