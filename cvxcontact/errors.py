"""Exceptions and warnings of cvxcontact.

Every error the package raises on bad input is a :class:`CvxContactError`; the
subclasses name the stage that refused the input. They also derive from the
built-in exception a caller would naturally catch (``ValueError`` for bad data,
``RuntimeError`` for a failed solve).
"""


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


class UnsupportedError(CvxContactError, NotImplementedError):
    """A feature the API names but this version does not provide yet (e.g. a contact law other than
    non-penetration, a force-controlled obstacle); the message says which."""
