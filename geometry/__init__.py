"""Pure numerics of conformorph: arrays in, arrays out; no I/O.

The conformal core follows M.-H. Yueh, X. D. Gu, W.-W. Lin, C.-T. Wu and
S.-T. Yau, "Conformal Surface Registration with Applications on Face
Morphing"; the 2D morph follows Yan, Hu and Martin, "Morphing of 2D shapes by
strain-field interpolation".
"""

from .angle_distortion import angle_distortion, corner_angles
from .beltrami_coefficient import beltrami_coefficient
from .boundary_loop import boundary_loop, boundary_loops
from .conformal_factor import conformal_factor
from .cotangent_laplacian import cotangent_laplacian, cotangent_weights
from .disk_conformal_map import DiskMapInfo, disk_conformal_map, vertex_areas
from .flipped_triangles import flipped_triangles, signed_areas_2d
from .map_quality import MapQuality, map_quality
from .mean_curvature import mean_curvature, mean_curvature_vector
from .mean_value_weights import mean_value_laplacian
from .mesh_edges import MeshEdges, mesh_edges
from .mesh_errors import (
    BoundaryEarError,
    FaceIndexError,
    FoldedMapError,
    MeshError,
    MultipleComponentsError,
    NonFiniteCoordinatesError,
    NonManifoldError,
    NotDiskError,
    NotTrianglesError,
    SingularSystemError,
    UnreferencedVertexError,
    ZeroAreaFaceError,
)
from .mesh_repair import fill_holes, remove_boundary_ears
from .mobius import mobius_disk, normalize_disk_map
from .reconstruct_surface import (
    ReconstructionInfo,
    ReconstructionOperator,
    reconstruct_surface,
    reconstruction_operator,
)
from .reconstruction_error import reconstruction_error
from .sparse_factor import Factorization, factorize
from .validate_mesh import MeshReport, boundary_ear_vertices, triangle_areas, validate_mesh
from .vertex_normals import vertex_normals

__all__ = [
    "BoundaryEarError",
    "DiskMapInfo",
    "FaceIndexError",
    "Factorization",
    "FoldedMapError",
    "MeshEdges",
    "MeshError",
    "MeshReport",
    "MultipleComponentsError",
    "NonFiniteCoordinatesError",
    "NonManifoldError",
    "NotDiskError",
    "NotTrianglesError",
    "ReconstructionInfo",
    "ReconstructionOperator",
    "SingularSystemError",
    "UnreferencedVertexError",
    "ZeroAreaFaceError",
    "MapQuality",
    "angle_distortion",
    "beltrami_coefficient",
    "boundary_ear_vertices",
    "boundary_loop",
    "boundary_loops",
    "conformal_factor",
    "corner_angles",
    "cotangent_laplacian",
    "cotangent_weights",
    "disk_conformal_map",
    "factorize",
    "fill_holes",
    "flipped_triangles",
    "map_quality",
    "mean_curvature",
    "mean_curvature_vector",
    "mean_value_laplacian",
    "mesh_edges",
    "mobius_disk",
    "normalize_disk_map",
    "reconstruct_surface",
    "reconstruction_error",
    "reconstruction_operator",
    "remove_boundary_ears",
    "signed_areas_2d",
    "triangle_areas",
    "validate_mesh",
    "vertex_areas",
    "vertex_normals",
]
