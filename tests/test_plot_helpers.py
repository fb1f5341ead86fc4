"""The figure helpers of cvxcontact.io.plot: the P2 quadratic trace and the rounding-level rule."""

import numpy as np

import cvxcontact as cc
from cvxcontact.io.plot import ROUNDING, at_rounding, quadratic_trace


def test_quadratic_trace_reproduces_a_quadratic_on_each_segment():
    x = np.array([0.0, 0.1, 0.2, 0.45, 0.7, 0.75, 0.8])       # vertices and midpoints, uneven segments
    f = lambda s: 3.0 * s ** 2 - s + 0.5                       # noqa: E731
    xs, vs = quadratic_trace(x, f(x))
    assert np.abs(vs - f(xs)).max() < 1e-14                    # measured 2.2e-16
    assert xs.min() == 0.0 and xs.max() == 0.8


def test_rounding_level_values_are_drawn_as_zero_with_their_magnitude():
    v, note = at_rounding([1e-21, -3e-21], scale=1e-5)
    assert not v.any() and note == 3e-21
    v, note = at_rounding([2e-9, 1e-9], scale=1e-5)          # 2e-4 of the scale: a real value
    assert note is None and v[0] == 2e-9
    assert at_rounding([0.0, 0.0], 1.0)[1] is None and ROUNDING == 1e-12


def test_stack_contact_figure_states_the_rounding_level_jump():
    """The stack example (every node of both pairs closed): its jumps are rounding (measured 2e-21 m against
    max|u| ~ 1e-5 m), drawn as 0 with their magnitude stated, not magnified into "[nm] x 1e-12"."""
    import runpy
    from pathlib import Path

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from cvxcontact.io.plot import plot_contact

    build = runpy.run_path(str(Path(__file__).resolve().parents[1] / "examples" / "stack.py"))["build"]
    sol = cc.solve(build(6))
    scale = max(np.abs(u).max() for u in sol.u)
    tiny = [np.abs(c.jump).max() for c in sol.contacts]
    assert all(0 < t <= ROUNDING * scale for t in tiny), (tiny, scale)
    fig = plot_contact(sol)
    try:
        jump_axes = [ax for ax in fig.axes if "jump" in ax.get_ylabel()]
        assert len(jump_axes) == 2
        for ax in jump_axes:
            notes = [t.get_text() for t in ax.texts]
            assert len(notes) == 1 and "rounding, drawn as 0" in notes[0]
            assert all(not np.any(ln.get_ydata()) for ln in ax.lines if "jump" in ln.get_label())
    finally:
        plt.close(fig)
