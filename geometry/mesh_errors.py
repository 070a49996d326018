"""Exception types raised when an input mesh cannot be processed.

Every failure has its own type so that callers (CLI, API) can map it to a
clear message; every type derives from :class:`MeshError`, itself a
:class:`ValueError`.
"""

from __future__ import annotations


class MeshError(ValueError):
    """Base class of all mesh validation errors."""

    #: short machine-readable name used in API error bodies
    code = "mesh_error"


class NotTrianglesError(MeshError):
    """Faces are not triangles, or arrays have the wrong shape or dtype."""

    code = "not_triangles"


class NonFiniteCoordinatesError(MeshError):
    """Some vertex coordinates are NaN or infinite."""

    code = "non_finite_coordinates"


class FaceIndexError(MeshError):
    """A face index is out of range, or repeated within one face.

    The base of :class:`FaceIndexOutOfRangeError` and
    :class:`RepeatedFaceIndexError`, which are what validation raises.
    """

    code = "bad_face_index"


class FaceIndexOutOfRangeError(FaceIndexError):
    """A face refers to a vertex index outside ``0 .. n-1``."""

    code = "face_index_out_of_range"


class RepeatedFaceIndexError(FaceIndexError):
    """A face names the same vertex twice (a degenerate triangle by indices)."""

    code = "repeated_face_index"


class ZeroAreaFaceError(MeshError):
    """A triangle has (numerically) zero area."""

    code = "zero_area_face"


class UnreferencedVertexError(MeshError):
    """A vertex is used by no face."""

    code = "unreferenced_vertex"


class NonManifoldError(MeshError):
    """An edge is shared by more than two faces, or a vertex is non-manifold."""

    code = "non_manifold"


class MultipleComponentsError(MeshError):
    """The mesh has more than one connected component."""

    code = "multiple_components"


class NotDiskError(MeshError):
    """The mesh is not a topological disk (one boundary loop, χ = 1)."""

    code = "not_disk"


class BoundaryEarError(MeshError):
    """Boundary vertices lie in a single triangle ("ears")."""

    code = "boundary_ears"


class SingularSystemError(ArithmeticError):
    """A sparse factorisation or solve was singular or produced non-finite values."""

    code = "singular_system"


class FoldedMapError(ArithmeticError):
    """A map that must be bijective has folded (flipped) triangles."""

    code = "folded_map"
