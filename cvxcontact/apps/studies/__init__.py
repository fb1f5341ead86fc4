"""Verification studies: Hertz contact (2D, and a sphere in 3D), convergence rates, speed against accuracy, stability,
the effectivity of the error estimate and of the guaranteed bound, adaptive against uniform refinement.

Each study module has ``run(out, quick=False, progress=None) -> dict`` that writes a CSV,
PNG figure(s) and a Markdown summary into ``out``; ``cvxcontact study NAME`` calls it.
``quick=True`` is a reduced version (about a minute on 2 cores) that the test suite runs.
"""

STUDIES = ("hertz", "convergence", "convergence_hencky", "speed", "stability", "hertz3d", "hertz3d_elastic", "estimate",
           "adapt", "bound")
