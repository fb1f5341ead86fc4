"""Exceptions and warnings of cvxcontact.

Every error the package raises on bad input is a :class:`CvxContactError`; the
subclasses name the stage that refused the input. They also derive from the
built-in exception a caller would naturally catch (``ValueError`` for bad data,
``RuntimeError`` for a failed solve).

Below the errors, the immutability of built descriptions: :class:`Frozen` (objects),
:class:`FrozenTuple` and :class:`FrozenMap` (their containers), each refusing an edit with a
:class:`FrozenError` that names what to build instead; and the descriptions' and problems' read-only arrays,
under three contracts: :func:`locked` (a dense copy whose values are read-only for good), :func:`frozen` (a sparse
matrix made canonical, its values and pattern read-only, in place) and :func:`frozen_pattern` (a sparse matrix's
pattern read-only in place, its values left writeable).
"""

from __future__ import annotations

import os
import sys
import warnings
from collections.abc import Iterable, Mapping
from typing import TYPE_CHECKING

if TYPE_CHECKING:                       # annotations only: ``cvxcontact --help`` must not load numpy (locked)
    import numpy as np
    import scipy.sparse as sp
    from numpy.typing import ArrayLike, DTypeLike


class CvxContactError(Exception):
    """Base class of all cvxcontact errors."""


class MeshError(CvxContactError, ValueError):
    """A mesh is malformed: bad arrays, inverted or degenerate triangles, unknown tags."""


class MaterialError(CvxContactError, ValueError):
    """Material constants are not finite, not symmetric or not positive definite."""


class SceneError(CvxContactError, ValueError):
    """Bodies, boundary parts, loads or the contact interface do not make a well-posed scene."""


class SolverError(CvxContactError, RuntimeError):
    """The convex solver failed or returned no usable solution."""


class ResidualWarning(UserWarning):
    """A solution failed the mixed-formulation checks at the requested tolerance."""


class FixedPointWarning(UserWarning):
    """A fixed point (Coulomb friction's, on the slip thresholds) stopped at its iteration limit before its
    tolerance: the answer is its iterate of smallest change, and its checks say how far it is from the law. The
    message says the change reached and what to do (more iterations, a smaller coefficient, a finer load step)."""


class ResolutionWarning(UserWarning):
    """The mesh cannot resolve what the solution shows: a contact zone spanned by too few cells (fewer than
    :data:`cvxcontact.solution.resolution.MIN_CELLS` contact faces of a body across it, 2D and 3D), or
    carried by cells of aspect ratio above :data:`cvxcontact.solution.resolution.MAX_ASPECT`. The discrete
    problem may be solved exactly (``ok`` True) while the pressure is far from the physics; the message names
    the pair, the body, the part and what to refine or remesh."""


class NonUniqueWarning(UserWarning):
    """The discrete problem has several solutions and one is returned: a force-controlled obstacle's
    translation along a direction no contact carrying force sees (a sphere touching one node on its axis)
    is free within the interval its open rows allow; the displacements, potentials, contact forces and
    the other translations are the same for every solution. The message names the direction."""


class OverlapWarning(UserWarning):
    """Friction capacities that do not scale with a pair's own normal force (a given threshold: ``cc.Tresca``)
    add where several obstacle pairs reach the same node of one body's contact part: the slip there is resisted
    by g1 + g2 (times the node's weight), not by one threshold, while the normal forces (and Coulomb's capacity
    mu lambda) are shared between the pairs. Raised when the problem is derived (before the solve), once per
    problem; a warning, not a refusal (overlapping thresholds may be meant). The message names the pairs, the
    part, the nodes and the area (length in 2D) where they overlap, the summed threshold and the fix. ``about``:
    (scene body index, part, the pairs' indices), what it says the same on every mesh of the scene (``cc.adapt``
    issues it once, not at every step)."""


def user_stacklevel() -> int:
    """The ``stacklevel`` of ``warnings.warn`` called where this is called that names the first frame outside the
    cvxcontact package: the user's line, however many of the package's calls lie between (``cvxcontact.solve``,
    ``ContactSolver.solve``, ``ContactSolver.solve_many``, ``Model.solve`` and ``cvxcontact.adapt`` reach the same
    warning through different depths). Every ``warnings.warn`` of the package passes it
    (tests/test_warning_location.py)."""
    package = os.path.dirname(os.path.abspath(__file__)) + os.sep
    frame, level = sys._getframe(1), 1
    while frame is not None and os.path.abspath(frame.f_code.co_filename).startswith(package):
        frame, level = frame.f_back, level + 1
    return level


def reissue(caught: Iterable[warnings.WarningMessage]) -> None:
    """Issue again warnings recorded inside the package (``warnings.catch_warnings(record=True)``), each at the
    file and line it named and under the module that line belongs to, so that the caller's filters apply to it as
    to a warning issued there: ``filterwarnings(module=...)`` matches a module's name (``warn_explicit`` without
    ``module`` would match the file's path without ".py" instead), and the once-per-place registry is the
    module's. The module is read from the frame of the call stack running that file (the caller's line, named by
    :func:`user_stacklevel`), else from the imported module of that file, else from the file's name.

    The de-duplication of the actions "default", "module" and "once" holds as for a warning issued there
    (:func:`_shown_before`): the package's own ``catch_warnings`` (each step of ``cc.adapt``) changes the filters'
    version, which empties every registry, so each step and each call printed the same warning again."""
    for w in caught:
        frame, where = sys._getframe(1), None
        while frame is not None and where is None:
            where = frame.f_globals if frame.f_code.co_filename == w.filename else None
            frame = frame.f_back
        if where is None:                   # a module's own dict: no module __getattr__ (a lazy import) is run
            where = next((d for d in (getattr(m, "__dict__", None) for m in list(sys.modules.values()))
                          if isinstance(d, dict) and d.get("__file__") == w.filename), None)
        if where is None:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
        elif not _shown_before(w, where.get("__name__")):
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno, module=where.get("__name__"),
                                   registry=where.setdefault("__warningregistry__", {}), module_globals=where)


_SHOWN: dict = {}
"""What :func:`reissue` has shown under a de-duplicating action: {module name: (the filters list object, its
contents, the keys shown)}."""


def _shown_before(w: warnings.WarningMessage, module: str | None) -> bool:
    """Whether the caller's filters (``warnings.filters`` as it is now) de-duplicate the recorded warning ``w``
    issued under ``module`` ("default": per text, category and line; "module": per text and category in the module;
    "once": per text and category in the module, as CPython's ``_warnings`` does where a registry is given, as
    here, rather than in the process-wide ``onceregistry``) and :func:`reissue` showed it already under the same
    filters: the same list object (a caller's ``catch_warnings`` makes a new one; the package's own restores it)
    with the same entries
    (``filterwarnings``, ``simplefilter`` and ``resetwarnings`` change them). Python's registries forget what they
    showed at any change of the filters, the package's own ``catch_warnings`` included; this record does not
    forget on those, nor on a caller's that leave the same list and entries behind (an empty ``catch_warnings``
    block, a filter added again unchanged), where Python's would. Records ``w`` as shown if it will be."""
    text = str(w.message) if isinstance(w.message, Warning) else w.message
    category = w.message.__class__ if isinstance(w.message, Warning) else w.category
    action = next((a for a, msg, cat, mod, line in warnings.filters
                   if _matches(msg, text) and issubclass(category, cat) and _matches(mod, module or "")
                   and (line == 0 or line == w.lineno)),
                  warnings.defaultaction)
    key = {"default": (text, category, w.lineno), "module": (text, category, 0),
           "once": (text, category, 0)}.get(action)
    if key is None:
        return False
    scope, filters = module, warnings.filters
    same, contents, shown = _SHOWN.get(scope, (None, None, set()))
    if same is not filters or contents != tuple(filters):
        shown = set()
    seen = key in shown
    shown.add(key)
    _SHOWN[scope] = (filters, tuple(filters), shown)
    return seen


def _matches(pattern, text: str) -> bool:
    """Whether a filter's message or module entry matches ``text`` as Python's own filter matching does: None
    matches all, a plain string only itself (Python's built-in default filters hold one, the module "__main__" of
    ``('default', None, DeprecationWarning, '__main__', 0)``), a compiled pattern where it matches at the start."""
    if pattern is None:
        return True
    if type(pattern) is str:
        return pattern == text
    return pattern.match(text) is not None


class SweepResultsError(CvxContactError, ValueError):
    """A folder that is not a sweep's output, an unknown case id, or a case without a complete result (not
    computed, failed, or its files damaged: the message names the file and, for a record of the wrong shape,
    the field)."""


class UnsupportedError(CvxContactError, NotImplementedError):
    """A feature the API names but this version does not provide yet (e.g. a contact law other than
    non-penetration, a force-controlled obstacle); the message says which."""


class FrozenError(SceneError, AttributeError):
    """A built description (a Mesh, Body, Load, Contact, Rigid or Scene, or one of their tuples and
    mappings) was edited. They are immutable, so that nothing a solver prepared from them can silently
    disagree with what the user holds; the message names what to build instead (the ``with_*`` variants).
    An ``AttributeError`` too, so ``hasattr`` and ``getattr(obj, name, default)`` keep their meaning."""


# --------------------------------------------------------------------------- immutability

class Frozen:
    """Mixin: an object that cannot be changed once built.

    Assigning or deleting an attribute raises :class:`FrozenError` naming the attribute and the
    variant to build instead (:meth:`_frozen_hint`). ``__init__`` sets the attributes with
    :meth:`_set`; ``functools.cached_property`` still works (it writes the instance ``__dict__``).
    """

    __slots__ = ()

    def _set(self, **fields) -> None:
        """Set attributes while the object is being built."""
        for name, value in fields.items():
            object.__setattr__(self, name, value)

    def _frozen_hint(self, name: str) -> str:
        """What to do instead of changing ``name`` (overridden by each description)."""
        return f"build a new {type(self).__name__}"

    def __setattr__(self, name, value):
        raise FrozenError(_refusal(f"{type(self).__name__}.{name}", "assigned", self._frozen_hint(name)))

    def __delattr__(self, name):
        raise FrozenError(_refusal(f"{type(self).__name__}.{name}", "deleted", self._frozen_hint(name)))

    def __setstate__(self, state: dict) -> None:
        """Unpickled or deep-copied: its arrays read-only again (:func:`locked`; pickle restores them writeable)."""
        self.__dict__.update({k: _relocked(v) for k, v in state.items()})


def locked(a: ArrayLike, dtype: DTypeLike | None = None) -> np.ndarray:
    """A copy of ``a`` (C order, same shape; ``dtype``: converted to it, None: ``a``'s) read-only for good: its
    memory is a ``bytes`` object, so no ``setflags(write=True)`` (of it or of its ``base``) makes it writeable
    again, as it would an array that owns its data. A description edited in place would leave what was computed
    from it once (a mesh's areas, a prepared solver's loads) silently stale. The dense contract; the sparse ones:
    :func:`frozen`, :func:`frozen_pattern`."""
    import numpy as np                  # here, not at the top: ``cvxcontact --help`` must not load numpy

    shape = np.shape(a)
    a = np.ascontiguousarray(a, dtype=dtype)
    return np.frombuffer(a.tobytes(), dtype=a.dtype).reshape(shape)


def frozen(A: sp.spmatrix | None) -> sp.spmatrix | None:
    """``A`` in canonical form with read-only arrays (values and pattern): a compressed sparse matrix (CSR/CSC)
    gets its indices sorted and its duplicates summed, in place, once (explicit zeros are kept), then its
    ``data``, ``indices`` and ``indptr`` made read-only; a matrix without ``indptr`` (COO, DIA...), or None, is
    returned as it is. Returns ``A``.

    What a :class:`~cvxcontact.discrete.problem.DiscreteProblem` holds is only read by a solve, yet SciPy sorts a
    non-canonical matrix in place on first use by some operations (``abs(A)``, ``A.sum_duplicates()``): the order
    of its entries, and with it the rounding of sums over them, changed between a problem's first and its second
    solve. In canonical form nothing is left to sort, and any in-place change raises at once (ValueError).
    Unlike :func:`locked`, the arrays are ``A``'s own (no copy), and ``setflags(write=True)`` would unlock them."""
    if getattr(A, "indptr", None) is None:
        return A
    if not A.has_canonical_format:
        A.sum_duplicates()
    for a in (A.data, A.indices, A.indptr):
        a.flags.writeable = False
    return A


def frozen_pattern(A: sp.spmatrix) -> sp.spmatrix:
    """``A`` (CSR/CSC) with its pattern read-only, in place: ``indices`` and ``indptr`` (not its values, nor put
    in canonical form). For matrices that share one pattern across many values (a strain energy's Hessians; the
    sparse route's K(A) for every active set locks its raw arrays likewise, backends.pattern.MixedPattern): a
    caller's in-place change of the pattern (``eliminate_zeros``, ``sort_indices`` of an unsorted one,
    ``indices[...] = ...``) raises (ValueError) instead of changing the sparsity under the other matrices and the
    places kept for those arrays. Returns ``A``."""
    A.indices.flags.writeable = False
    A.indptr.flags.writeable = False
    return A


def _relocked(v):
    """``v`` with the arrays in it (directly, or in a tuple, :class:`FrozenMap` or dict, e.g. a mesh's kept
    ``cells_at``) :func:`locked`."""
    np = sys.modules.get("numpy")           # not imported at the top (see locked): unloaded, v is no array
    if np is not None and isinstance(v, np.ndarray):
        return locked(v)
    if isinstance(v, FrozenMap):
        return FrozenMap({k: _relocked(x) for k, x in v.items()}, *v._edit)
    if isinstance(v, FrozenTuple):
        return FrozenTuple([_relocked(x) for x in v], *v._edit)
    if type(v) is tuple:
        return tuple(_relocked(x) for x in v)
    if type(v) is dict:
        return {k: _relocked(x) for k, x in v.items()}
    return v


def _refusal(what, how, hint):
    return f"{what} cannot be {how}: a built description is immutable; {hint}"


class _RefusesEdits:
    """Mixin of :class:`FrozenTuple` and :class:`FrozenMap`: the editing methods of the mutable type they stand
    for (``_EDITS``, named ``_KIND`` in the message) and item or attribute assignment raise
    :class:`FrozenError` naming the attribute (``_edit[0]``) and the variant to build (``_edit[1]``)."""

    __slots__ = ()
    _EDITS: frozenset = frozenset()
    _KIND = ""

    def __getattr__(self, name):
        if name in type(self)._EDITS:
            what, hint = object.__getattribute__(self, "_edit")
            raise FrozenError(_refusal(f"{what} ({self._KIND})", f"changed with .{name}()", hint))
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    def __setitem__(self, key, value):
        raise FrozenError(_refusal(f"{self._edit[0]}[{key!r}]", "assigned", self._edit[1]))

    def __delitem__(self, key):
        raise FrozenError(_refusal(f"{self._edit[0]}[{key!r}]", "deleted", self._edit[1]))

    def __setattr__(self, name, value):
        raise FrozenError(_refusal(f"{self._edit[0]}.{name}", "assigned", self._edit[1]))


class FrozenTuple(_RefusesEdits, tuple):
    """A tuple that says what to do when edited as if it were a list: ``body.roller.append("left")``
    raises :class:`FrozenError` naming the attribute (``what``) and the variant to build (``hint``)."""

    _EDITS = frozenset({"append", "extend", "insert", "remove", "pop", "clear", "sort", "reverse"})
    _KIND = "a tuple"

    def __new__(cls, items=(), what: str = "this tuple", hint: str = "build a new description"):
        out = super().__new__(cls, items)
        object.__setattr__(out, "_edit", (what, hint))
        return out

    def __reduce__(self):
        return (FrozenTuple, (tuple(self), *self._edit))


class FrozenMap(_RefusesEdits, Mapping):
    """A read-only mapping (insertion order kept) that says what to do when edited:
    ``body.traction["right"] = ...`` raises :class:`FrozenError` naming the attribute and the variant."""

    __slots__ = ("_items", "_edit")
    _EDITS = frozenset({"update", "pop", "popitem", "setdefault", "clear"})
    _KIND = "a read-only mapping"

    def __init__(self, items=(), what: str = "this mapping", hint: str = "build a new description"):
        object.__setattr__(self, "_items", dict(items))
        object.__setattr__(self, "_edit", (what, hint))

    def __getitem__(self, key):
        return self._items[key]

    def __iter__(self):
        return iter(self._items)

    def __len__(self):
        return len(self._items)

    def __repr__(self):
        return repr(self._items)

    def __eq__(self, other):
        return dict(self._items) == dict(other) if isinstance(other, Mapping) else NotImplemented

    __hash__ = None

    def __reduce__(self):
        return (FrozenMap, (self._items, *self._edit))
