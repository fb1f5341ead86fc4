"""Normal contact laws on Gamma_3: Signorini (the default) and normal compliance (the paper's (7), (17), (19)).

With r = [u_nu] - g the penetration (m; the paper's [u_nu] with the gap g subtracted):

``Signorini()``
    r <= 0, lambda >= 0, lambda r = 0 (the paper's (8); the package's original problem).
``NormalCompliance(stiffness=k, exponent=m, penetration_limit=None)``
    lambda = -sigma_nu = p(r) = k r_+^m (Pa), k > 0 in Pa/m^m, m >= 1: the law (7) with a p_nu
    that satisfies (17)(b)-(d) (monotone, zero for r <= 0; Lipschitz, (17)(a), for m = 1). It is
    the derivative of the convex energy density Phi(r) = k/(m+1) r_+^{m+1} (J/m^2), so (19) is the
    optimality condition of the energy of docs/formulation.md §2 plus integral_Gamma3 Phi(r).
    With ``penetration_limit`` = l (m, >= 0) the law holds for r <= l and Signorini holds at
    r = l: r <= l, lambda = p(r) + mu, mu >= 0, mu (r - l) = 0.

``Tresca(threshold=g)``
    Signorini in the normal direction and Tresca friction with a given threshold g (Pa): the energy
    gains integral_Gamma3 g |[v_t]| (docs/howto/friction.md), one cone
    t_a >= |[u_t](x_a)| per contact row with weight g w_a; the tangential traction sigma_t lies in
    the ball of radius g, (g - |sigma_t|) |[u_t]| = 0, and sigma_t is anti-parallel to the slip.
``Coulomb(coefficient=mu)``
    Signorini in the normal direction and Coulomb friction: Tresca with the threshold g = mu lambda_nu
    (the normal pressure), found by a fixed point on the thresholds (docs/howto/friction.md, "Coulomb").

A law answers two questions of the discrete problem (the contact-term protocol): its normal part
(``compliant`` and, for compliance, the parameters of :class:`RowLaws`) and its tangential part,
``friction``: None (frictionless) or an object with ``thresholds(normal_pressure)`` (Pa per row) that
says how the rows' slip is penalised, and ``pressure_dependent``: Tresca's thresholds do not depend on the
normal pressure; Coulomb's, mu lambda_nu, do, and the friction route finds them by a fixed point
(:mod:`cvxcontact.backends.friction`) with the law's ``tolerance`` and ``max_iterations``.

Laws are small frozen classes; :func:`check_law` validates a ``law=`` argument (None -> Signorini)
and raises :class:`~cvxcontact.errors.SceneError` (a :class:`~cvxcontact.errors.CvxContactError`)
naming what is wrong. The discretisation (the energy lumped on the contact nodes) is in
docs/formulation.md §10.

Each contact pair may carry its own law (``Contact.law``; None: the law given to ``solve``), see
:func:`pair_laws`; :class:`RowLaws` holds the law of every stacked contact row (a Signorini row is
k = 0 with the limit l = 0), which is what the backends, the finish and the checks see.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

import numpy as np

from ..errors import SceneError

__all__ = ["ContactLaw", "Signorini", "NormalCompliance", "Tresca", "Coulomb", "check_law", "check_law_for", "pair_laws", "RowLaws", "LAWS"]


class ContactLaw:
    """Base class of the normal contact laws (``Signorini``, ``NormalCompliance``)."""

    name = "law"

    @property
    def compliant(self) -> bool:
        """True if the law allows penetration with a finite pressure (normal compliance)."""
        return False

    @property
    def friction(self):
        """The law's tangential part: None (frictionless), or an object with ``thresholds(pressure)`` giving
        the slip threshold (Pa) of each row from its normal pressure (Pa), e.g. :class:`Tresca`."""
        return None


@dataclass(frozen=True)
class Signorini(ContactLaw):
    """Unilateral contact without penetration: r <= 0, lambda >= 0, lambda r = 0 (the paper's (8))."""

    name = "signorini"


def _positive_real(value, what, allow_zero=False, law="NormalCompliance"):
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise SceneError(f"{law}: {what} must be a real number, got {value!r} ({type(value).__name__})")
    value = float(value)
    if not math.isfinite(value):
        raise SceneError(f"{law}: {what} must be finite, got {value!r}")
    if value < 0 or (value == 0 and not allow_zero):
        raise SceneError(f"{law}: {what} must be {'>= 0' if allow_zero else '> 0'}, got {value!r}")
    return value


@dataclass(frozen=True)
class NormalCompliance(ContactLaw):
    """Normal compliance lambda = p(r) = k r_+^m, r = [u_nu] - g (module docstring).

    Parameters
    ----------
    stiffness : float
        k > 0, Pa/m^m (Pa/m for the linear law m = 1).
    exponent : float
        m >= 1 (dimensionless); m = 1 is the linear (penalty-like) law.
    penetration_limit : float or None
        l >= 0 (m): beyond it Signorini holds (r <= l). None: no limit.

    Raises
    ------
    SceneError
        A parameter that is not a finite real number in its range (NaN, k <= 0, m < 1, l < 0).
    """

    stiffness: float
    exponent: float = 1.0
    penetration_limit: float | None = None
    name = "normal_compliance"

    def __post_init__(self):
        object.__setattr__(self, "stiffness", _positive_real(self.stiffness, "stiffness (Pa/m^m)"))
        m = _positive_real(self.exponent, "exponent")
        if m < 1:
            raise SceneError(f"NormalCompliance: exponent must be >= 1 (p convex in r_+, (17)), got {m!r}")
        object.__setattr__(self, "exponent", m)
        if self.penetration_limit is not None:
            object.__setattr__(self, "penetration_limit",
                               _positive_real(self.penetration_limit, "penetration_limit (m)", allow_zero=True))

    @property
    def compliant(self) -> bool:
        return True

    def pressure(self, r) -> np.ndarray:
        """p(r) = k r_+^m (Pa) at penetrations r (m)."""
        return _pressure(self.stiffness, self.exponent, r)

    def derivative(self, r) -> np.ndarray:
        """p'(r) = k m r_+^(m-1) (Pa/m; for m = 1 the right derivative k at r = 0 is not used: 0 there)."""
        return _derivative(self.stiffness, self.exponent, r)

    def energy(self, r) -> np.ndarray:
        """Phi(r) = k/(m+1) r_+^(m+1) (J/m^2), the primitive of p vanishing for r <= 0."""
        return _energy(self.stiffness, self.exponent, r)

    def scaled(self, pressure: float, displacement: float) -> "NormalCompliance":
        """The same law in units where pressure is ``pressure`` (Pa) and penetration ``displacement`` (m):
        k~ = k U^m / P, l~ = l / U."""
        limit = None if self.penetration_limit is None else self.penetration_limit / displacement
        return NormalCompliance(self.stiffness * displacement ** self.exponent / pressure, self.exponent, limit)


@dataclass(frozen=True)
class Tresca(ContactLaw):
    """Signorini normal contact with Tresca friction of a given threshold (module docstring).

    Parameters
    ----------
    threshold : float
        g >= 0 (Pa): the largest tangential traction |sigma_t| the contact transmits before it slips;
        the friction energy is integral_Gamma3 g |[u_t]| (J/m in 2D). g = 0 is frictionless.

    Raises
    ------
    SceneError
        A threshold that is not a finite real number >= 0.
    """

    threshold: float
    name = "tresca"

    def __post_init__(self):
        object.__setattr__(self, "threshold", _positive_real(self.threshold, "threshold (Pa)", allow_zero=True,
                                                             law="Tresca"))

    @property
    def friction(self) -> "Tresca":
        return self

    def thresholds(self, pressure) -> np.ndarray:
        """The slip threshold g (Pa) at rows with normal pressure ``pressure`` (Pa): g everywhere (Tresca's
        threshold is given, not the normal pressure's)."""
        return np.full(np.shape(pressure), self.threshold)

    @property
    def pressure_dependent(self) -> bool:
        """False: the threshold is given."""
        return False


@dataclass(frozen=True)
class Coulomb(ContactLaw):
    """Signorini normal contact with Coulomb friction: |sigma_t| <= mu |sigma_nu| (module docstring).

    Solved as Tresca with the thresholds g = mu lambda_nu of the previous iterate's normal pressure, a fixed
    point from the stuck contact (docs/howto/friction.md, "Coulomb").

    Parameters
    ----------
    coefficient : float
        mu >= 0 (dimensionless): the friction coefficient. mu = 0 is frictionless.
    tolerance : float
        The fixed point stops when the thresholds change by at most ``tolerance`` relative to the largest
        (> 0; default 1e-12). The stick-slip check is the square root of a product, so a change d of the
        thresholds shows there as ~sqrt(d |s_a| / U): on a sheared layer (tests/test_coulomb.py) a change of
        5e-10 left it at 4.8e-6, 7e-13 at 6.1e-7, which is the interior point's own level (8.6e-15: 6.1e-7).
    max_iterations : int
        Iterations at most (>= 1); beyond them the answer is the iterate of smallest change, with a
        :class:`~cvxcontact.errors.FixedPointWarning` (its checks then say how far it is from Coulomb's law).

    Raises
    ------
    SceneError
        A coefficient that is not a finite real number >= 0, a tolerance not > 0, max_iterations not >= 1.
    """

    coefficient: float
    tolerance: float = 1e-12
    max_iterations: int = 50
    name = "coulomb"

    def __post_init__(self):
        object.__setattr__(self, "coefficient", _positive_real(self.coefficient, "coefficient", allow_zero=True,
                                                               law="Coulomb"))
        object.__setattr__(self, "tolerance", _positive_real(self.tolerance, "tolerance", law="Coulomb"))
        n = self.max_iterations
        if isinstance(n, bool) or not isinstance(n, numbers.Integral) or n < 1:
            raise SceneError(f"Coulomb: max_iterations must be an integer >= 1, got {n!r}")
        object.__setattr__(self, "max_iterations", int(n))

    @property
    def friction(self) -> Coulomb:
        return self

    def thresholds(self, pressure) -> np.ndarray:
        """The slip threshold mu lambda_nu (Pa) at rows with normal pressure ``pressure`` (Pa; a tension,
        never reached at a solution, counts as 0)."""
        return self.coefficient * np.maximum(np.asarray(pressure, dtype=float), 0.0)

    @property
    def pressure_dependent(self) -> bool:
        """True: the threshold is the pressure's (a fixed point)."""
        return True


LAWS = {"signorini": Signorini, "normal_compliance": NormalCompliance, "tresca": Tresca, "coulomb": Coulomb}
"""Law names as written in scene files."""


def check_law(law) -> ContactLaw:
    """A validated law: None gives ``Signorini()``; a :class:`ContactLaw` instance is returned as is."""
    if law is None:
        return Signorini()
    if isinstance(law, ContactLaw):
        return law
    if isinstance(law, type) and issubclass(law, ContactLaw):
        raise SceneError(f"law must be an instance such as cc.Signorini() or cc.NormalCompliance(stiffness=...), "
                         f"got the class {law.__name__}")
    raise SceneError(f"law must be cc.Signorini(), cc.NormalCompliance(stiffness=k, exponent=m), "
                     f"cc.Tresca(threshold=g) or cc.Coulomb(coefficient=mu), got {law!r} "
                     f"({type(law).__name__})")


def check_law_for(scene, law: ContactLaw) -> ContactLaw:
    """``law`` (the law given to ``solve``/``Model``) once the scene's pairs are known to support it.

    Every pair takes its own ``Contact.law`` or, if None, ``law`` (:func:`pair_laws`); any mix of
    Signorini, normal-compliance and friction pairs (:class:`Tresca`, :class:`Coulomb`; 2D, and 3D with planar
    contact parts), between bodies or against rigid obstacles, is posed here. A pair is either compliant in the
    normal direction (frictionless) or frictional (Signorini in the normal direction): no law here is both. The
    refusals that remain are the space's and the terms' (P2 "gamma3" cones with friction beside a compliance law:
    no contact term declares that combination, :data:`cvxcontact.discrete.terms.UNPOSED`)."""
    pair_laws(scene, law)
    return law


def pair_laws(scene, law: ContactLaw) -> tuple:
    """The law of each contact pair of ``scene``: the pair's own ``Contact.law``, or ``law`` (the one
    given to ``solve``/``Model``; None is ``Signorini()``, :func:`check_law`) where it is None."""
    law = check_law(law)
    return tuple(law if getattr(c, "law", None) is None else c.law for c in scene.contacts)


class RowLaws:
    """The normal law of every stacked contact row (docs/formulation.md §10, per pair).

    ``RowLaws(laws, counts)``: pair i has law ``laws[i]`` on ``counts[i]`` consecutive rows. Per row a
    (arrays of the total row count):

    ``stiffness`` k_a (Pa/m^m; 0 on Signorini rows), ``exponent`` m_a (1 on Signorini rows),
    ``penetration_limit`` l_a (m; 0 on Signorini rows, ``inf`` for a compliance row without a limit).

    A Signorini row is the compliance law with k = 0 and limit 0 (p vanishes on r <= 0), so one
    formulation covers every mix: the energy sum_a w_a Phi_a(r_a) over the compliant rows and the
    rows r_a <= l_a where l_a is finite. ``pressure``, ``derivative``, ``energy`` act row-wise like
    those of :class:`NormalCompliance`; ``scaled`` gives the same rows in scaled units.
    """

    def __init__(self, laws, counts):
        self.laws = tuple(check_law(law) for law in laws)
        self.counts = tuple(int(n) for n in counts)
        if len(self.laws) != len(self.counts):
            raise SceneError(f"RowLaws: {len(self.laws)} laws for {len(self.counts)} pairs")
        k, m, ell = [], [], []
        for law in self.laws:
            if law.compliant:
                lim = law.penetration_limit
                k.append(law.stiffness), m.append(law.exponent), ell.append(np.inf if lim is None else lim)
            else:
                k.append(0.0), m.append(1.0), ell.append(0.0)
        rep = lambda v: np.repeat(np.asarray(v, dtype=float), self.counts)  # noqa: E731
        self.stiffness, self.exponent, self.penetration_limit = rep(k), rep(m), rep(ell)
        self.frictional = rep([law.friction is not None for law in self.laws]).astype(bool)
        self.pressure_dependent = rep([law.friction is not None and law.friction.pressure_dependent
                                       for law in self.laws]).astype(bool)
        for a in (self.stiffness, self.exponent, self.penetration_limit, self.frictional, self.pressure_dependent):
            a.setflags(write=False)

    @classmethod
    def uniform(cls, law, n: int) -> "RowLaws":
        """One law on ``n`` rows."""
        return cls([law], [n])

    @property
    def size(self) -> int:
        """Number of rows."""
        return len(self.stiffness)

    @property
    def rows(self) -> np.ndarray:
        """Boolean mask of the compliant rows (k_a > 0)."""
        return self.stiffness > 0

    @property
    def compliant(self) -> bool:
        """True if some row follows a normal-compliance law."""
        return bool(self.rows.any())

    @property
    def friction(self) -> bool:
        """True if some row has a tangential (friction) part (``frictional``: the mask of those rows)."""
        return bool(self.frictional.any())

    @property
    def fixed_point(self) -> tuple[float, int] | None:
        """(tolerance, max_iterations) of the fixed point on the thresholds if some row's threshold depends
        on the pressure (the finest tolerance and the most iterations of those laws), else None."""
        laws = [law.friction for law in self.laws if law.friction is not None and law.friction.pressure_dependent]
        if not laws:
            return None
        return min(f.tolerance for f in laws), max(f.max_iterations for f in laws)

    def thresholds(self, pressure) -> np.ndarray:
        """The slip threshold (Pa) of every row from the rows' normal pressures (Pa): each pair's
        ``law.friction.thresholds`` on its rows, 0 on frictionless rows (``pressure_dependent``: the mask of
        the rows whose threshold depends on the pressure)."""
        pressure = np.broadcast_to(np.asarray(pressure, dtype=float), (self.size,))
        out, start = np.zeros(self.size), 0
        for law, n in zip(self.laws, self.counts):
            if law.friction is not None:
                out[start:start + n] = law.friction.thresholds(pressure[start:start + n])
            start += n
        return out

    @property
    def limited(self) -> np.ndarray:
        """Boolean mask of the rows with a condition r_a <= l_a (Signorini rows and compliance limits)."""
        return np.isfinite(self.penetration_limit)

    @property
    def linear(self) -> bool:
        """True if every compliant row is linear (m = 1) without a penetration limit."""
        on = self.rows
        return bool((self.exponent[on] == 1).all() and not np.isfinite(self.penetration_limit[on]).any())

    def pressure(self, r) -> np.ndarray:
        """p_a(r_a) = k_a (r_a)_+^m_a (Pa; 0 on Signorini rows)."""
        return _pressure(self.stiffness, self.exponent, r)

    def derivative(self, r) -> np.ndarray:
        """p_a'(r_a) (Pa/m; 0 where r_a <= 0 and on Signorini rows)."""
        return _derivative(self.stiffness, self.exponent, r)

    def energy(self, r) -> np.ndarray:
        """Phi_a(r_a) = k_a/(m_a+1) (r_a)_+^(m_a+1) (J/m^2; 0 on Signorini rows)."""
        return _energy(self.stiffness, self.exponent, r)

    def scaled(self, pressure: float, displacement: float) -> "RowLaws":
        """The same rows in units of ``pressure`` (Pa) and ``displacement`` (m) (:meth:`NormalCompliance.scaled`)."""
        return RowLaws([law.scaled(pressure, displacement) if law.compliant else law for law in self.laws],
                       self.counts)


def _pressure(k, m, r):
    """p(r) = k r_+^m (Pa); k, m scalars or per-row arrays."""
    return k * np.maximum(np.asarray(r, dtype=float), 0.0) ** m


def _derivative(k, m, r):
    """p'(r) = k m r_+^(m-1) (Pa/m), 0 where r <= 0."""
    r = np.maximum(np.asarray(r, dtype=float), 0.0)
    return np.where(r > 0, k * m * r ** (m - 1.0), 0.0)


def _energy(k, m, r):
    """Phi(r) = k/(m+1) r_+^(m+1) (J/m^2), the primitive of p vanishing for r <= 0."""
    return k / (m + 1.0) * np.maximum(np.asarray(r, dtype=float), 0.0) ** (m + 1.0)

