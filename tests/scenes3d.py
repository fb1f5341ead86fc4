"""Canonical 3D scenes (4-node tetrahedra, cc.box meshes), shared by tests, examples and benchmarks.

Each builder returns a cc.Scene small enough to solve in well under 2 s; ``SCENES3D`` maps a name to
(builder, keywords of cc.solve). The closed forms of the patch scenes are beside their builders
(``uniaxial_modulus``, ``floating_potential``); tests/test_contact3d.py checks every scene against them or
against an independent dense solve of the mixed system (26).
"""

import inspect
import sys

import numpy as np

import cvxcontact as cc

E, NU, P = 70e9, 0.3, 1e6          # Pa, -, Pa
SIDES = ["left", "right", "front", "back"]
STEEL = cc.materials.isotropic(E=E, nu=NU)


def uniaxial_modulus(E=E, nu=NU) -> float:
    """The constrained (oedometric) modulus c33 = E (1 - nu) / ((1 + nu) (1 - 2 nu)) of an isotropic
    material, Pa: the stiffness of a layer held by rollers on its four sides."""
    return E * (1 - nu) / ((1 + nu) * (1 - 2 * nu))


def stiffened_modulus(material) -> float:
    """c33 + e33^2 / eps33 (Pa) of a material poled along z: the uniaxial stiffness along the poling axis
    with D_z = 0 (an open-circuit electrode), from the material's 3D Voigt tensors."""
    return float(material.c3[2, 2] + material.e3[2, 2] ** 2 / material.kappa3[2, 2])


def floating_potential(material, p=P, height=0.5) -> float:
    """The potential (V) of the open-circuit top electrode of a layer of ``height`` (m) poled along z,
    grounded at its base, under a pressure ``p`` with rollers on its sides: S3 = -p / (c33 + e33^2/eps33),
    D3 = e33 S3 + eps33 E3 = 0, so E3 = -e33 S3 / eps33 and phi(top) = -E3 height."""
    S3 = -p / stiffened_modulus(material)
    return float(material.e3[2, 2] * S3 / material.kappa3[2, 2] * height)


def layer_on_plane(material=STEEL, n=(3, 3, 2), p=P, height=0.5, piezo=False):
    """A layer (0, 1) x (0, 1) x (0, height) m held by rollers on its four sides, pressed by ``p`` (Pa) on
    its top onto the rigid plane z = 0 (its only support along z). ``piezo``: grounded base (the contact
    face) and an open-circuit (zero-charge) floating top electrode."""
    mesh = cc.box(x=(0, 1), y=(0, 1), z=(0, height), nx=n[0], ny=n[1], nz=n[2])
    electric = dict(grounded="bottom", floating={"top": 0.0}) if piezo else {}
    body = cc.Body(mesh, material, roller=SIDES, contact="bottom", traction={"top": (0, 0, -p)}, name="layer",
                   **electric)
    return cc.Scene(body, contacts=[cc.Contact(body, "bottom", cc.Rigid.plane((0, 0, 0), (0, 0, 1)))])


def pzt_layer_on_plane(n=(3, 3, 2), p=P):
    """:func:`layer_on_plane` of PZT-5A poled along z with the electrodes described there."""
    return layer_on_plane(cc.materials.PZT5A, n, p, piezo=True)


def stacked_blocks(lower=(5, 5), upper=(7, 3), p=P, material=STEEL, nz=2, gap=0.0):
    """Two blocks (0, 1)^2 x (0, 0.5) and (0, 1)^2 x (0.5, 1) m with ``lower`` and ``upper`` cells across
    their common face z = 0.5 (non-matching by default), rollers on every side face and under the lower
    block, the pressure ``p`` (Pa) on the upper block's top: the uniaxial solution u_z = -p z / c33."""
    low = cc.box(x=(0, 1), y=(0, 1), z=(0, .5), nx=lower[0], ny=lower[1], nz=nz)
    up = cc.box(x=(0, 1), y=(0, 1), z=(.5, 1), nx=upper[0], ny=upper[1], nz=nz)
    b1 = cc.Body(low, material, roller=SIDES + ["bottom"], contact="top", name="lower")
    b2 = cc.Body(up, material, roller=SIDES, contact="bottom", traction={"top": (0, 0, -p)}, name="upper")
    return cc.Scene(b1, b2, gap=gap)


def bumped_gap(x, y):
    """0.2 r^2 mm, r the distance (m) from the faces' centre (0.5, 0.5) (a gap g(s1, s2) of the plane z = 0.5)."""
    return 2e-4 * ((np.asarray(x) - .5) ** 2 + (np.asarray(y) - .5) ** 2)


def tilted_gap(x, y):
    """An affine gap, 0.05 x mm (its P1 interpolant on any overlay is itself)."""
    return 5e-5 * np.asarray(x) + 0 * np.asarray(y)


def bumped_blocks(lower=(4, 4), upper=(5, 3), load=2e7, gap=bumped_gap, material=STEEL, nz=2):
    """Two blocks on (0, 1)^2 (lower clamped at its base, of ``material``; upper held by rollers on two sides)
    meeting at z = 0.5 with the gap ``gap`` (default :func:`bumped_gap`, opening away from the centre), the upper
    pushed by a traction ``load`` (Pa) on a central square of its top: a contact zone with an edge inside
    the faces. ``nz`` cells through each block."""
    low = cc.box(x=(0, 1), y=(0, 1), z=(0, .5), nx=lower[0], ny=lower[1], nz=nz)
    up = cc.box(x=(0, 1), y=(0, 1), z=(.5, 1), nx=upper[0], ny=upper[1], nz=nz)
    press = lambda x, y, z: np.where((np.abs(x - .5) < .3) & (np.abs(y - .5) < .3), -load, 0.0)
    b1 = cc.Body(low, material, clamped="bottom", contact="top", name="lower")
    b2 = cc.Body(up, STEEL, roller=["left", "front"], contact="bottom", name="upper",
                 traction={"top": lambda x, y, z: (0 * x, 0 * x, press(x, y, z))})
    return cc.Scene(b1, b2, gap=gap)


def pzt_on_block(material, volts=50.0, lower=(2, 2), upper=(3, 2), load=2e7, nz=1):
    """:func:`bumped_blocks` with a PZT-5A upper block (poled along z, driven at ``volts`` on its top, no grounded
    electrode: its potential is fixed by the top alone) on a lower block of ``material``."""
    scene = bumped_blocks(lower, upper, load=load, material=material, nz=nz)
    low, up = scene.bodies
    return cc.Scene(low, up.with_changes(material=cc.materials.PZT5A, potential={"top": volts}), gap=bumped_gap)


def pressed_blocks(lower=(3, 3), upper=(4, 2), d=2e-5, gap=bumped_gap, nz=1, material=STEEL):
    """Two blocks on (0, 1)^2 meeting at z = 0.5 with non-matching faces: the lower (of ``material``) clamped at
    its base, the upper pushed down by d (m) on its top (both held by their supports), the gap ``gap``."""
    low = cc.box(x=(0, 1), y=(0, 1), z=(0, .5), nx=lower[0], ny=lower[1], nz=nz)
    up = cc.box(x=(0, 1), y=(0, 1), z=(.5, 1), nx=upper[0], ny=upper[1], nz=nz)
    b1 = cc.Body(low, material, clamped="bottom", contact="top", name="lower")
    b2 = cc.Body(up, STEEL, displacement={"top": (0.0, 0.0, -d)}, contact="bottom", name="upper")
    return cc.Scene(b1, b2, gap=gap)


def pressed_key():
    """(key, make) of conftest's ``shared`` for the P2 answer of :func:`pressed_blocks` (its defaults) under
    "gamma3", the method "auto" (the condensed route): ``shared(*pressed_key())``, read by several test modules."""
    return ("P2 pressed blocks, gamma3, auto",), lambda: cc.solve(pressed_blocks(), "gamma3", degree=2)


def sphere_on_block(force=2e9, n=(6, 6, 3), material=STEEL):
    """A rigid sphere (radius 1 m) under the prescribed force (0, 0, -force) N on a block (-0.5, 0.5)^2 x
    (-0.5, 0) m of ``material`` clamped at its base, touching its top at the centre: about 9 contact nodes at
    2e9 N."""
    mesh = cc.box(x=(-.5, .5), y=(-.5, .5), z=(-.5, 0), nx=n[0], ny=n[1], nz=n[2])
    body = cc.Body(mesh, material, clamped="bottom", contact="top", name="block")
    ball = cc.Rigid.sphere((0, 0, 1.0), 1.0, force=(0, 0, -force))
    return cc.Scene(body, contacts=[cc.Contact(body, "top", ball)])


def watched_checks(scene, **options):
    """(the "gamma3" solution of ``scene`` under ``options``, a ResolutionWarning ignored; the arguments
    ``solution.checks.conic_checks`` read the answer with, by name: blocks, u, phi, r, B, g, beta, ...)."""
    import warnings

    import pytest

    from cvxcontact.solution import nodal

    seen, checks = {}, nodal.conic_checks

    def spy(*args, **kwargs):
        seen.update(zip(("blocks", "u", "phi", "r", "B", "g", "beta"), args), **kwargs)
        return checks(*args, **kwargs)

    with pytest.MonkeyPatch.context() as mp, warnings.catch_warnings():
        warnings.simplefilter("ignore", cc.ResolutionWarning)
        mp.setattr(nodal, "conic_checks", spy)
        sol = cc.solve(scene, "gamma3", **options)
    return sol, seen


def sphere_cones_key():
    """(key, make) of conftest's ``shared`` for the P2 "gamma3" answer of :func:`sphere_on_block` (4 x 4 x 2 cells)
    on the full route with the arguments its checks read (:func:`watched_checks`): (solution, arguments), read by
    tests/test_check_rounding_cones.py and test_forced_condensed.py (``shared(*sphere_cones_key())``; the method
    "auto" takes the full route here: the same answer bit for bit)."""
    return ("P2 cones under a force-controlled sphere, 4 x 4 x 2, full",), \
        lambda: watched_checks(sphere_on_block(n=(4, 4, 2)), degree=2, method="full")


def three_blocks(counts=((4, 4), (3, 5), (5, 3)), p=P, conditions=("gamma3", "gamma3"), middle=STEEL):
    """Three blocks of height 1/3 m stacked on (0, 1)^2 (rollers on their sides, the lowest on its base),
    their faces non-matching (``counts`` cells across each block), pressed by ``p`` on the top: the
    uniaxial solution through two contact pairs. ``middle``: the middle block's material (the others STEEL)."""
    zs = (0.0, 1 / 3, 2 / 3, 1.0)
    bodies = []
    for k, (c, name) in enumerate(zip(counts, ("bottom block", "middle block", "top block"))):
        mesh = cc.box(x=(0, 1), y=(0, 1), z=(zs[k], zs[k + 1]), nx=c[0], ny=c[1], nz=1)
        extra = dict(traction={"top": (0, 0, -p)}) if k == 2 else {}
        bodies.append(cc.Body(mesh, middle if k == 1 else STEEL, roller=SIDES + (["bottom"] if k == 0 else []),
                              name=name, **extra))
    low, mid, top = bodies
    pairs = [cc.Contact(low, "top", mid, "bottom", condition=conditions[0]),
             cc.Contact(mid, "top", top, "bottom", condition=conditions[1])]
    return cc.Scene(*bodies, contacts=pairs)


PAD = ("top", (0.25, 0.75), (0.25, 0.75))
"""The named patch "pad" of the base of :func:`punch_on_pad`: face, x range, y range (m)."""


def punch_on_pad(load=5e7):
    """A punch (0.5, 1.1) x (0.4, 0.9) x (0.5, 0.8) m pressed by ``load`` (Pa) on its top onto the patch
    "pad" (0.25, 0.75)^2 of the top of a base (0, 1)^2 x (0, 0.5) clamped at its bottom: the pair's faces
    overlap only on (0.5, 0.75) x (0.4, 0.75). The punch is held by rollers on its left and front faces and
    by the contact."""
    base = cc.box(x=(0, 1), y=(0, 1), z=(0, .5), nx=4, ny=4, nz=2, patches={"pad": PAD})
    punch = cc.box(x=(.5, 1.1), y=(.4, .9), z=(.5, .8), nx=3, ny=3, nz=1)
    b1 = cc.Body(base, STEEL, clamped="bottom", name="base")
    b2 = cc.Body(punch, STEEL, roller=["left", "front"], traction={"top": (0, 0, -load)}, name="punch")
    return cc.Scene(b1, b2, contacts=[cc.Contact(b1, "pad", b2, "bottom")])


def rotation() -> np.ndarray:
    """A generic rotation (about no coordinate axis; angle 1.2 rad about (1, -2, 0.7)/|.|)."""
    a = np.array([1.0, -2.0, 0.7]) / np.linalg.norm([1.0, -2.0, 0.7])
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(1.2) * K + (1 - np.cos(1.2)) * K @ K


def piezo_pair(R=None, lower=(3, 3), upper=(2, 4), load=1e6, volts=50.0):
    """Two PZT-5A blocks poled along z (their material turned by R, default the identity) meeting at
    z = 0.5: the lower clamped and grounded at its base, the upper driven at ``volts`` on its top, which
    carries a traction (load/3, -load/4, -load) Pa, and held by rollers on its left and front faces. With R
    the whole scene (points, materials, tractions) is turned by R; the rollers are planar faces and turn
    with it."""
    R = np.eye(3) if R is None else np.asarray(R, dtype=float)
    low = cc.box(x=(0, 1), y=(0, 1), z=(0, .5), nx=lower[0], ny=lower[1], nz=2)
    up = cc.box(x=(0, 1), y=(0, 1), z=(.5, 1), nx=upper[0], ny=upper[1], nz=2)
    low, up = (m.with_points(m.points @ R.T) for m in (low, up))
    pzt = cc.materials.PZT5A.rotated(R)
    t = R @ np.array([load / 3, -load / 4, -load])
    b1 = cc.Body(low, pzt, clamped="bottom", grounded="bottom", contact="top", name="lower")
    b2 = cc.Body(up, pzt, roller=["left", "front"], contact="bottom", traction={"top": tuple(t)},
                 potential={"top": volts}, name="upper")
    return cc.Scene(b1, b2)


def extruded_pair(n=4, width=None):
    """The 3D counterpart of :func:`section_pair`: the same section (x, z) extruded along y over ``width``
    (default one cell, 1/n m) with rollers on its front and back faces (u_y = 0: plane strain)."""
    w = 1.0 / n if width is None else width
    low = cc.box(x=(0, 1), y=(0, w), z=(0, .5), nx=n, ny=1, nz=n // 2)
    up = cc.box(x=(0.2, 0.8), y=(0, w), z=(.5, .8), nx=n, ny=1, nz=n // 2)
    pzt = cc.materials.PZT5A
    b1 = cc.Body(low, pzt, clamped="bottom", grounded="bottom", roller=["front", "back"], contact="top",
                 name="lower")
    b2 = cc.Body(up, pzt, roller=["left", "front", "back"], grounded="top", contact="bottom", name="upper",
                 traction={"top": lambda x, y, z: (2e6 * (x - .5), 0 * x, -1e7 * (1 + x))})
    return cc.Scene(b1, b2, contacts=[cc.Contact(b1, "top", b2, "bottom", gap=_section_gap)])


def section_pair(n=4):
    """Two PZT-5A blocks in the 2D model plane (x, y = 3D z; plane strain, poled along y): the lower
    (0, 1) x (0, 0.5) m clamped and grounded at its base, the upper (0.2, 0.8) x (0.5, 0.8) m grounded on its
    top, held by a roller on its left side and pressed by a traction varying along x on its top, with a gap
    opening away from x = 0.5 (:func:`_section_gap`)."""
    low = cc.rectangle(x=(0, 1), y=(0, .5), nx=n, ny=n // 2)
    up = cc.rectangle(x=(0.2, 0.8), y=(.5, .8), nx=n, ny=n // 2)
    pzt = cc.materials.PZT5A
    b1 = cc.Body(low, pzt, clamped="bottom", grounded="bottom", contact="top", name="lower")
    b2 = cc.Body(up, pzt, roller="left", grounded="top", contact="bottom", name="upper",
                 traction={"top": lambda x, y: (2e6 * (x - .5), -1e7 * (1 + x))})
    return cc.Scene(b1, b2, contacts=[cc.Contact(b1, "top", b2, "bottom", gap=_section_gap)])


def two_boxes(n=4, condition="sigma1", elastic=False):
    """A PZT-5A box (0, 1)^2 x (0, 0.5) m (n x n x n/2 cells, clamped and grounded on top, body force 2e9 N/m^3
    downwards, traction 3e8 Pa along z on its right face, surface charge -0.05 C/m^2 on its left face) on an
    aluminium box (0, 1)^2 x (-0.5, 0) m (about 0.7 n cells a side, clamped at the bottom): non-matching faces
    on z = 0 under ``condition``, the 3D analogue of ``demo.two_blocks`` (benchmarks/bench3d.py). ``elastic``:
    the upper box aluminium too (no potentials)."""
    n = max(2, int(n))
    n2 = max(2, round(0.7 * n))
    aluminium = cc.materials.isotropic(E=70e9, nu=0.3, name="aluminium")
    upper = cc.box(x=(0.0, 1.0), y=(0.0, 1.0), z=(0.0, 0.5), nx=n, ny=n, nz=max(1, n // 2))
    lower = cc.box(x=(0.0, 1.0), y=(0.0, 1.0), z=(-0.5, 0.0), nx=n2, ny=n2, nz=max(1, (n2 + 1) // 2))
    if elastic:
        b1 = cc.Body(upper, aluminium, clamped=["top"], name="upper box", body_force=(0.0, 0.0, -2e9),
                     traction={"right": (0.0, 0.0, 3e8)})
    else:
        b1 = cc.Body(upper, cc.materials.PZT5A, clamped=["top"], grounded=["top"], name="PZT-5A box",
                     body_force=(0.0, 0.0, -2e9), traction={"right": (0.0, 0.0, 3e8)},
                     surface_charge={"left": -0.05})
    b2 = cc.Body(lower, aluminium, clamped=["bottom"], name="aluminium box")
    return cc.Scene(b1, b2, contacts=[cc.Contact(b1, "bottom", b2, "top", condition=condition)])


def offset_boxes(n=6, offset=3e-7):
    """Two aluminium boxes on z = 0 whose faces' grids have the same spacing h = 1/n, the lower's grid lines
    ``offset`` h off the upper's in x and y (upper (0, 1)^2 x (0, 0.5) m, n x n x n/2 cells, clamped on top, body
    force 2e9 N/m^3 downwards, traction 3e8 Pa along z on its right face; lower n + 1 cells a side from
    (offset - 1) h, clamped at the bottom), "gamma3": every overlay vertex has a partner ``offset`` h away, so
    that at offset 1e-7 .. 5e-7 the rows carrying the forces pass the rows' own independence test
    (DEPENDENT_PIVOT) while W on them is singular to SINGULAR_PIVOT (issue 33: the exact finish declined)."""
    n = max(2, int(n))
    h = 1.0 / n
    aluminium = cc.materials.isotropic(E=70e9, nu=0.3, name="aluminium")
    upper = cc.box(x=(0.0, 1.0), y=(0.0, 1.0), z=(0.0, 0.5), nx=n, ny=n, nz=max(1, n // 2))
    x0 = (offset - 1.0) * h
    lower = cc.box(x=(x0, x0 + (n + 1) * h), y=(x0, x0 + (n + 1) * h), z=(-0.5, 0.0), nx=n + 1, ny=n + 1,
                   nz=max(1, n // 2))
    b1 = cc.Body(upper, aluminium, clamped=["top"], name="upper box", body_force=(0.0, 0.0, -2e9),
                 traction={"right": (0.0, 0.0, 3e8)})
    b2 = cc.Body(lower, aluminium, clamped=["bottom"], name="lower box")
    return cc.Scene(b1, b2, contacts=[cc.Contact(b1, "bottom", b2, "top", condition="gamma3")])


def sphere_into_block(n=6, radius=2.0, depth=0.02, law=None):
    """An aluminium block (-1, 1)^2 x (-1, 0) m (n x n x n/2 cells, clamped at the bottom) pressed ``depth`` (m)
    deep by a fixed rigid sphere of ``radius`` (m; 2 m, 0.02 m: a Hertz contact whose zone, radius about 0.2 m, is
    a small part of the rows, one per top node; benchmarks/bench3d.py), ``law`` on the pair (None: Signorini)."""
    n = max(2, int(n))
    block = cc.box(x=(-1.0, 1.0), y=(-1.0, 1.0), z=(-1.0, 0.0), nx=n, ny=n, nz=max(1, n // 2))
    body = cc.Body(block, cc.materials.isotropic(E=70e9, nu=0.3, name="aluminium"), clamped=["bottom"],
                   name="aluminium block")
    ball = cc.Rigid.sphere((0.0, 0.0, radius - depth), radius)
    return cc.Scene(body, contacts=[cc.Contact(body, "top", ball, law=law)])


def _section_gap(x, *rest):
    """1e-3 (x - 0.5)^2 m, x the abscissa: the 2D gap g(s, y) and the 3D g(s1, s2) (s1 = x on a plane z = const)."""
    return 1e-3 * (np.asarray(x, dtype=float) - 0.5) ** 2


SCENES3D = {
    "layer on a rigid plane, gamma3": (layer_on_plane, dict(condition="gamma3")),
    "layer on a rigid plane, sigma1": (layer_on_plane, dict(condition="sigma1")),
    "PZT-5A layer, floating electrode": (pzt_layer_on_plane, dict(condition="gamma3")),
    "stacked blocks 5x5 on 7x3, gamma3": (stacked_blocks, dict(condition="gamma3")),
    "stacked blocks 5x5 on 7x3, sigma1": (stacked_blocks, dict(condition="sigma1")),
    "stacked blocks, nested 2x2 in 4x4, sigma2": (lambda: stacked_blocks((2, 2), (4, 4)), dict(condition="sigma2")),
    "bumped blocks, gamma3": (bumped_blocks, dict(condition="gamma3")),
    "force-controlled sphere": (sphere_on_block, dict(condition="gamma3")),
    "three blocks": (three_blocks, dict(condition="gamma3")),
    "punch on a patch": (punch_on_pad, dict(condition="gamma3")),
    "two PZT blocks": (piezo_pair, dict(condition="sigma1")),
}
"""name -> (builder, keywords of cc.solve)."""


def _simplex_grid(n) -> np.ndarray:
    """Barycentric coordinates (p, 3) of the points of spacing 1/n on a triangle."""
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    keep = i + j <= n
    a, b = i[keep] / n, j[keep] / n
    return np.column_stack([1 - a - b, a, b])


def sampled_penetration(scene, sol, gap, pair=0, n=12):
    """[u_nu] - g (m) at the points of spacing 1/n of every overlay triangle of the P2 pair ``pair`` of ``scene``:
    the jump evaluated from each body's own P2 face functions at the point (not through X_h, nor the Bernstein form)
    and the gap function ``gap(x, y)`` itself (a quadratic: its P2 interpolant on a triangle is itself)."""
    from cvxcontact.contact.quadratic3d import locate, p2_shape
    from cvxcontact.fem.space import P2Tet

    lines = P2Tet().contact(scene, "gamma3", cc.Signorini()).interface
    itf = getattr(lines, "interfaces", (lines,))[pair]
    ov = itf.linear.overlay
    V = np.asarray(ov.vertices)
    x = np.einsum("pk,tkd->tpd", _simplex_grid(n), V[np.asarray(ov.triangles)]).reshape(-1, 2)
    jump = np.zeros(len(x))
    for trace, body in zip(itf.traces, itf.members):
        tri, bary = locate(x, np.asarray(trace.x), np.asarray(trace.faces)[:, :3])
        assert (tri >= 0).all()
        face = np.asarray(trace.nodes)[np.asarray(trace.faces)[tri]]
        jump += np.einsum("pk,pkd->pd", p2_shape(bary), sol.u[body][face]) @ np.asarray(trace.unit_normal)
    points = itf.offset * np.asarray(itf.normal) + x @ np.asarray(itf.frame)
    return jump - gap(points[:, 0], points[:, 1])


def default_builders() -> dict:
    """The scene builders of this module callable with their defaults, by name: every public function whose
    arguments all have defaults and whose return is not annotated (the helpers returning a number or an array are),
    ``pzt_on_block`` given ``STEEL``."""
    out = {}
    for name, f in inspect.getmembers(sys.modules[__name__], inspect.isfunction):
        if f.__module__ != __name__ or name.startswith("_") or f is default_builders:
            continue
        sig = inspect.signature(f)
        if sig.return_annotation is not inspect.Signature.empty:
            continue
        if name == "pzt_on_block":
            out[name] = lambda f=f: f(STEEL)
        elif all(p.default is not inspect.Parameter.empty for p in sig.parameters.values()):
            out[name] = f
    return out


def read_as_curved(monkeypatch, curved=1):
    """While ``monkeypatch`` is active, scenes built read their pairs' ``curved``-th part as curved (node-to-face,
    contact/surface.py ``CurvedSurfaceInterface``) though it is planar: on coplanar faces its rows are the
    overlay's nodal rows at that body's nodes (tests/test_hertz3d_elastic.py), a reference for curved parts."""
    import cvxcontact.physics.scene as scene_module
    from cvxcontact.contact.surface import CurvedSurfaceInterface, SurfaceInterface

    def forced(bodies, parts=None, obstacle=None):
        parts = tuple(b.contact for b in bodies) if parts is None else tuple(parts)
        if obstacle is not None:
            return SurfaceInterface(tuple(bodies), parts, obstacle=obstacle)
        return CurvedSurfaceInterface(tuple(bodies), parts, curved=curved)

    monkeypatch.setattr(scene_module, "pair_interface", forced)
