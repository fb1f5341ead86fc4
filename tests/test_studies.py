"""The verification studies run in their quick versions and their numbers make sense.

These are sanity bounds, wide on purpose: the studies' outputs are measurements to read,
not pass/fail targets; the assertions catch a study that is broken, not one that is slow.
"""

import csv

import pytest

from cvxcontact.apps.cli import main


def rows(path):
    with open(path) as fh:
        return list(csv.DictReader(fh))


@pytest.fixture(scope="module")
def studies(tmp_path_factory):
    out = tmp_path_factory.mktemp("studies")
    assert main(["study", "all", "--quick", "--out", str(out), "-q"]) == 0
    return out


def test_every_study_writes_csv_png_and_markdown(studies):
    for name in ("hertz", "convergence", "speed", "stability"):
        assert (studies / name / f"{name}.md").read_text().startswith("#")
        assert (studies / name / f"{name}.png").read_bytes()[:4] == b"\x89PNG"


def test_hertz_errors_shrink(studies):
    r = rows(studies / "hertz" / "hertz.csv")
    err = [abs(float(x["p0_rel_error"])) for x in r]
    assert err[-1] < err[0] and err[-1] < 0.3
    assert abs(float(r[-1]["a_rel_error"])) < 0.2


def test_convergence_energy_error_decreases(studies):
    for r in rows(studies / "convergence" / "convergence_rates.csv"):
        assert float(r["rate_energy"]) > 0.4, r


def test_speed_exact_finish_reaches_rounding(studies):
    r = rows(studies / "speed" / "speed.csv")
    finished = [float(x["solver_error"]) for x in r if "exact finish" in x["setting"]]
    assert finished and max(finished) < 1e-10
    loose = [float(x["solver_error"]) for x in r if x["setting"] == "Clarabel tol 1e-04"]
    assert min(loose) > max(finished)


def test_stability_merged_multipliers_lose_inf_sup(studies):
    r = [x for x in rows(studies / "stability" / "stability_infsup.csv") if x["study"] == "inf-sup"]
    matching = [x for x in r if x["n1"] == x["n2"]]
    skewed = [x for x in r if x["n1"] != x["n2"]]
    assert all(float(x["gamma3"]) > 0.1 for x in matching)
    assert max(float(x["gamma3"]) for x in skewed) < 0.1 < min(float(x["sigma1"]) for x in skewed)
    failures = rows(studies / "stability" / "stability_failures.csv")
    assert any(x["status"] == "error" for x in failures if "unscaled" in x["case"] and "1e-6" in x["case"])
