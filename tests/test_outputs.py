"""Outputs a scientist can use: the pressure felt by each body, VTU/PVD files, figures, the CLI's first hour."""

import json
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import meshio
import numpy as np
import pytest

import cvxcontact as cc
from cvxcontact.contact.interface import lumped_lengths

ROOT = Path(__file__).resolve().parents[1]


def interference(soft, nx=(7, 5), E=1e9, ratio=1e8, h=0.5, delta=1e-4):
    """Two nu = 0 blocks clamped at their far faces, pressed together by an interference ``delta`` (m).

    Body ``soft`` has Young's modulus E, the other E * ratio (nearly rigid). With nu = 0 the soft
    block is in uniaxial strain, so the exact contact pressure is E delta / h whatever its mesh:
    P1 reproduces it, and any error is of order 1/ratio."""
    mats = [cc.materials.isotropic(E=E * (1.0 if k == soft else ratio), nu=0.0) for k in range(2)]
    m1 = cc.rectangle(x=(0, 1), y=(0, h), nx=nx[0], ny=2)
    m2 = cc.rectangle(x=(0, 1), y=(-h, 0), nx=nx[1], ny=2)
    b1 = cc.Body(m1, mats[0], clamped=["top"], contact="bottom")
    b2 = cc.Body(m2, mats[1], clamped=["bottom"], contact="top")
    return cc.Scene(b1, b2, gap=-delta), E * delta / h


@pytest.mark.parametrize("condition,soft", [("sigma1", 0), ("sigma2", 1), ("gamma3", 0), ("gamma3", 1)])
def test_pressure_of_uniform_compression_is_exact_on_non_matching_meshes(condition, soft):
    """The nodal pressure divides each force by the lumped length of the mesh that carries it
    (mesh l for sigma_l). Dividing by the merged mesh's lengths (the former bias) is off by tens of %."""
    scene, p = interference(soft)
    sol = cc.solve(scene, condition)
    c = sol.contact
    x, felt = sol.traction(soft)
    assert sol.ok and np.abs(felt / p - 1).max() < 1e-6
    if condition != "gamma3":
        assert np.abs(c.pressure[c.constrained] / p - 1).max() < 1e-6
        assert np.all(c.pressure[~c.constrained] == 0)
        biased = c.force[c.constrained] / lumped_lengths(c.x)[c.constrained]      # the former definition
        assert np.abs(biased / p - 1).max() > 0.1
