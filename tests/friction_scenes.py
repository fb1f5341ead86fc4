"""The 2D friction scenes shared by tests/test_tresca.py and tests/test_coulomb.py: a steel block 1 m x 0.5 m
on a rigid floor, pressed by p on its top (a fixtures module: the test modules do not import each other)."""

import cvxcontact as cc

E, P, L, H = 200e9, 1e7, 1.0, 0.5
FLOOR = cc.Rigid.plane(point=(0.0, 0.0), normal=(0.0, 1.0))


def steel(nu=0.3, scale=1.0):
    return cc.materials.isotropic(E=E * scale, nu=nu)


def sheared(q, law, tied=False, nx=8, ny=4):
    """The block under (q, -p) on its top, ``law`` on its contact; ``tied``: frictionless contact, u_x = 0 on the
    contact edges (the same edges under a second tag "base")."""
    m = cc.rectangle(x=(0.0, L), y=(0.0, H), nx=nx, ny=ny)
    if tied:
        m = cc.Mesh(m.points, m.triangles, {**{t: m.boundary(t) for t in m.tags}, "base": m.boundary("bottom")})
        b = cc.Body(m, steel(), contact="bottom", traction={"top": (q, -P)}, displacement={"base": (0.0, None)})
        return cc.Scene(b, contacts=[cc.Contact(b, "bottom", FLOOR)])
    b = cc.Body(m, steel(), contact="bottom", traction={"top": (q, -P)})
    return cc.Scene(b, contacts=[cc.Contact(b, "bottom", FLOOR, law=law)])


def pushed(law, s=1e-4):
    """The nu = 0 block pushed by u_x = s on its left face, pressed by p: (its mesh, the scene)."""
    m = cc.rectangle(x=(0.0, L), y=(0.0, H), nx=8, ny=4)
    b = cc.Body(m, steel(nu=0.0), contact="bottom", traction={"top": (0.0, -P)}, displacement={"left": (s, None)})
    return m, cc.Scene(b, contacts=[cc.Contact(b, "bottom", FLOOR, law=law)])


def patch(law, tied=False, nx=8, ny=4):
    """The block with its left face above y = H / 4 held along x (u_x = 0: not the corner, whose row would then
    carry an undetermined force), pressed by p on [0.25, 0.625] of its top: held without
    friction too (``law`` None or cc.Signorini()), its base slides outwards under Poisson's expansion.
    ``tied``: frictionless contact with u_x = 0 on the contact edges (the same edges under a second tag "base")."""
    m = cc.rectangle(x=(0.0, L), y=(0.0, H), nx=nx, ny=ny, segments={"load": ("top", 0.25, 0.625), "side": ("left", H / 4, H)})
    held = {"side": (0.0, None)}
    if tied:
        m = cc.Mesh(m.points, m.triangles, {**{t: m.boundary(t) for t in m.tags}, "base": m.boundary("bottom")})
        held["base"] = (0.0, None)
    b = cc.Body(m, steel(), contact="bottom", traction={"load": (0.0, -P)}, displacement=held)
    return cc.Scene(b, contacts=[cc.Contact(b, "bottom", FLOOR, law=None if tied else law)])


FLOOR3D = cc.Rigid.plane(point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0))


def box(q, law, tied=False, nu=0.3, push=None, n=3):
    """A steel 1 m cube (n x n x 2 cells) on a rigid floor under (q_x, q_y, -p) on its top, ``law`` on its
    contact (tests/test_friction3d.py's scenes); ``tied``: frictionless, u_x = u_y = 0 on the contact faces;
    ``push`` (s_x, s_y): its left face moved so along x, y (then held there without friction too)."""
    mesh = cc.box(nx=n, ny=n, nz=2)
    held = {} if push is None else {"left": (push[0], push[1], None)}
    if tied:
        mesh = cc.TetMesh(mesh.points, mesh.tets, {**{t: mesh.boundary(t) for t in mesh.tags},
                                                   "base": mesh.boundary("bottom")})
        held["base"] = (0.0, 0.0, None)
    b = cc.Body(mesh, steel(nu=nu), contact="bottom", traction={"top": (q[0], q[1], -P)}, displacement=held)
    return cc.Scene(b, contacts=[cc.Contact(b, "bottom", FLOOR3D, law=None if tied else law)])
