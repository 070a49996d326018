"""Pure numerics of conformorph: arrays in, arrays out; no I/O.

The conformal core follows M.-H. Yueh, X. D. Gu, W.-W. Lin, C.-T. Wu and
S.-T. Yau, "Conformal Surface Registration with Applications on Face
Morphing"; the 2D morph follows Yan, Hu and Martin, "Morphing of 2D shapes by
strain-field interpolation".

Every public function and class of every public module is re-exported here
(``tests/geometry/test_package_exports.py`` keeps this list complete).
Constants and type aliases stay in their modules (shared tolerances in
:mod:`conformorph.geometry.tolerances`).

The names load on first use (:pep:`562`): ``import geometry`` costs nothing until a name
is used, so a command imports only the modules it runs (``conformorph morph`` starts
faster without the 2D morph's and the shape tools' modules). Type checkers read the
imports below; the package reads its own import statements to find each name's module.
"""

from __future__ import annotations

import sys
from typing import TYPE_CHECKING

from conformorph.geometry._lazy_exports import LazyPackage

if TYPE_CHECKING:
    from .angle_distortion import angle_distortion, corner_angles, corner_edge_products
    from .angle_refinement import AngleRefinementInfo, refine_angles, signed_corner_angles
    from .arap_interpolation import arap_interpolation
    from .beltrami_coefficient import beltrami_coefficient, triangle_frames
    from .biharmonic_fill import biharmonic_fill, uniform_laplacian
    from .boundary_anchors import BoundaryAnchors, boundary_anchors
    from .boundary_loop import boundary_loop, boundary_loops
    from .compatible_map_relaxation import relaxed_target
    from .compatible_mesh_quality import collapse_slivers, improve_quality, min_triangle_angle
    from .compatible_triangulation import CompatibleTriangulation, compatible_triangulation
    from .conformal_factor import conformal_factor
    from .conformal_relaxation import (
        RelaxationInfo,
        conformal_relaxation,
        mips_energy,
        symmetric_dirichlet_energy,
    )
    from .consistent_boundaries import ConsistentBoundary, consistent_boundaries
    from .consistent_mesh import (
        ConsistentMesh,
        consistent_mesh,
        landmark_disk_mesh,
        refine_disk_mesh,
        refinement_levels,
        resample_texture,
        resample_vertex_data,
        sample_image,
    )
    from .consistent_orientation import OrientedFaces, consistent_orientation
    from .cotangent_laplacian import cotangent_laplacian, cotangent_weights
    from .detail_transfer import DetailEmbedding, detail_embedding, transferred_points
    from .disk_conformal_map import DiskMapInfo, disk_conformal_map, green_disk_map
    from .disk_registration import (
        DiskRegistration,
        LandmarkTolerance,
        register_disk_landmarks,
        register_disk_landmarks_tolerant,
    )
    from .dissection_paths import DissectionAnchors, checked_paths, cut_polygons, dissection_anchors
    from .double_cover import DoubleCover, double_cover
    from .face_region import (
        FaceDirection,
        FaceRegion,
        FaceRegionError,
        face_direction,
        face_region,
    )
    from .faired_hole_filling import FilledHoles, fill_holes_faired, hole_patch_faces, patch_rings
    from .flip_repair import repair_flips
    from .flipped_triangles import flipped_triangles, max_orientation_step, signed_areas_2d
    from .fold_correction import FoldCorrectionInfo, fold_correction, fold_region, fold_residual
    from .fold_free_offsets import FoldFreeOffsets, fold_free_offsets
    from .green_lagrange_strain import (
        deformation_gradient,
        green_lagrange_strain,
        interpolate_strain,
        shape_function_gradients,
        signed_areas,
        strain_from_gradient,
    )
    from .hole_cuts import HoleCuts, check_hole_counts, hole_cuts
    from .hole_pairing import HolePairingOptions, HolePairs, pair_holes, ring_centroid_area
    from .hole_seeding import (
        HolePairing,
        HoleSeeding,
        SeededHole,
        seed_hole,
        seed_missing_holes,
        seeded_hole_pairing,
    )
    from .intrinsic_laplacian import (
        IntrinsicLaplacianPattern,
        edge_lengths,
        intrinsic_cotangent_laplacian,
        intrinsic_cotangents,
    )
    from .landmark_cross_validation import (
        CrossValidation,
        cross_validate_registration,
        landmark_folds,
    )
    from .landmark_pairs import landmark_rms, validate_landmark_pairs
    from .landmark_smoothing import LandmarkSmoothing, discrepancy_smoothing
    from .largest_component import ComponentSelection, largest_component
    from .linear_interpolation import linear_interpolation
    from .map_jacobian import FoldReport, fold_report, map_jacobian_determinants
    from .map_quality import (
        Histogram,
        MapQuality,
        boundary_isoperimetric_ratio,
        histogram,
        map_quality,
    )
    from .map_stretch import MapStretch, map_stretch, principal_stretches
    from .mean_curvature import mean_curvature, mean_curvature_vector
    from .mean_value_patches import PatchMaps, glue_cut, patch_maps
    from .mean_value_weights import mean_value_laplacian
    from .merged_triangulation import MergedPoints, refined_merged_triangulation
    from .mesh_cleanup import MeshCleanup, clean_mesh_elements
    from .mesh_edges import MeshEdges, mesh_boundary_vertices, mesh_edges
    from .mesh_errors import (
        BoundaryEarError,
        FaceIndexError,
        FaceIndexOutOfRangeError,
        FoldedMapError,
        MeshError,
        MultipleComponentsError,
        NonFiniteCoordinatesError,
        NonManifoldError,
        NotDiskError,
        NotTrianglesError,
        RepeatedFaceIndexError,
        SingularSystemError,
        UnreferencedVertexError,
        ZeroAreaFaceError,
    )
    from .mesh_repair import extend_uv_to_ears, fill_holes, remove_boundary_ears
    from .mobius import mobius_disk, normalize_disk_map
    from .mobius_registration import MobiusRegistrationInfo, MobiusTransform, mobius_registration
    from .morph_frames import (
        FrameSolveOptions,
        HomotopyKeys,
        MorphFrames,
        linear_vertex_frames,
        morph_frames,
    )
    from .morph_metrics_2d import MorphMetrics2D, morph_metrics_2d
    from .morph_pacing import even_pace_times, path_steps
    from .nonmanifold_split import ManifoldSplit, split_nonmanifold
    from .nonrigid_icp import ICPLandmarks, NonrigidICPOptions, NonrigidICPResult, nonrigid_icp
    from .outline_correspondence import MatchOptions, OutlineMatch, match_outlines
    from .outline_features import (
        FeatureOptions,
        OutlineFeatures,
        outline_features,
        ring_arc_positions,
        ring_points_at,
        turning_angles,
    )
    from .outline_simplification import SimplifiedRings, SimplifyOptions, simplify_rings
    from .parameter_overlay import overlay_triangle_count
    from .patch_dissection import (
        Patch,
        dissect_shapes,
        dissected_triangulation,
        glue_patches,
        outer_boundary_first,
        straight_side_vertices,
    )
    from .point_location import PointLocation, PointLocator, locate_points
    from .qiem_disk_map import (
        QiemInfo,
        QiemOptions,
        double_cover_gauss_map,
        harmonic_hemisphere_map,
        qiem_disk_conformal_map,
    )
    from .reconstruct_surface import (
        NoInteriorVertexError,
        ReconstructionInfo,
        ReconstructionOperator,
        ReconstructionOptions,
        curvature_direction_normals,
        normal_update_iteration,
        reconstruct_surface,
        reconstruction_operator,
    )
    from .reconstruction_error import reconstruction_error
    from .registration_error import disk_registration_error, surface_registration_error
    from .rigid_alignment import (
        LandmarkAlignmentInfo,
        RigidAlignmentOptions,
        SimilarityTransform,
        normalize_by_diameter,
        rigid_landmark_alignment,
        surface_diameter,
        umeyama_alignment,
    )
    from .rotation_interpolation import (
        interpolate_rotations,
        interpolate_similarity,
        rotation_to_quaternion_xyzw,
    )
    from .shape_rings import (
        AnchorOutsideShapeError,
        DuplicateAnchorError,
        HoleCorrespondenceError,
        PathError,
        SelfIntersectingRingError,
        ShapeError,
        ShapeRings,
        TooFewAnchorsError,
        check_anchors,
        distance_to_rings,
        points_in_ring,
        points_in_shape,
        ring_signed_area,
        validate_rings,
    )
    from .sparse_factor import Factorization, SymmetricRefactorization, factorize, preconditioned_cg
    from .spherical_conformal_map import (
        SphericalMapInfo,
        SphericalMapOptions,
        center_on_sphere,
        gauss_map,
        spherical_conformal_map,
    )
    from .spline_homotopy import SplineHomotopy, spline_homotopy
    from .static_correspondences import (
        StaticCorrespondenceOptions,
        StaticCorrespondences,
        farthest_point_samples,
        static_correspondences,
    )
    from .stereographic_projection import (
        equator_rotation,
        hemisphere_to_disk,
        inverse_stereographic_projection,
        normalize_boundary_to_circle,
        stereographic_projection,
    )
    from .strain_diagnostics import StrainMorphInfo, strain_morph_info
    from .strain_frames import (
        SolvedFrames,
        StrainMorphOptions,
        check_strain_morph_options,
        solve_frame,
        solve_frames,
    )
    from .strain_morph import strain_morph
    from .strain_newton import FrameResult, barrier_newton, continuation_newton, max_positive_step
    from .strain_rigid_motion import (
        RigidMotion,
        gauge_vertices,
        restore_rigid_motion,
        rigid_motion,
        to_gauge,
        wrap_angle,
    )
    from .strain_system import StrainSystem
    from .strain_targets import prescribed_area_ratio, strain_target
    from .surface_distance import SurfaceDistance, projected_barycentrics, surface_to_surface_error
    from .thin_plate_registration import (
        ComposedDeformation,
        ThinPlateDeformation,
        ThinPlateFitInfo,
        stepwise_thin_plate_registration,
        thin_plate_registration,
    )
    from .threads import available_threads, map_in_threads, row_blocks
    from .triangulate_shape import (
        point_inside_ring,
        triangulate_polygon,
        triangulate_segments,
        triangulate_shape,
    )
    from .validate_mesh import (
        MeshReport,
        as_mesh_arrays,
        boundary_ear_vertices,
        triangle_areas,
        validate_mesh,
        validate_mesh_elements,
    )
    from .vertex_areas import vertex_areas
    from .vertex_budget_collapse import budgeted_triangulation, collapse_to_vertex_budget
    from .vertex_normals import vertex_normals


__all__ = [
    "HolePairingOptions",
    "HolePairs",
    "pair_holes",
    "ring_centroid_area",
    "MatchOptions",
    "OutlineMatch",
    "match_outlines",
    "FeatureOptions",
    "OutlineFeatures",
    "outline_features",
    "ring_arc_positions",
    "ring_points_at",
    "turning_angles",
    "SimplifiedRings",
    "SimplifyOptions",
    "simplify_rings",
    "AnchorOutsideShapeError",
    "AngleRefinementInfo",
    "BoundaryEarError",
    "CompatibleTriangulation",
    "ComposedDeformation",
    "ConsistentMesh",
    "CrossValidation",
    "DiskMapInfo",
    "DiskRegistration",
    "DoubleCover",
    "DuplicateAnchorError",
    "FaceIndexError",
    "FaceIndexOutOfRangeError",
    "Factorization",
    "FoldCorrectionInfo",
    "FoldFreeOffsets",
    "FoldReport",
    "FoldedMapError",
    "Histogram",
    "HoleCorrespondenceError",
    "Patch",
    "PathError",
    "HoleSeeding",
    "IntrinsicLaplacianPattern",
    "LandmarkAlignmentInfo",
    "RigidAlignmentOptions",
    "MapQuality",
    "MapStretch",
    "MeshEdges",
    "MeshError",
    "MeshReport",
    "MobiusRegistrationInfo",
    "MobiusTransform",
    "FrameSolveOptions",
    "HomotopyKeys",
    "MorphFrames",
    "MorphMetrics2D",
    "MultipleComponentsError",
    "NonFiniteCoordinatesError",
    "NonManifoldError",
    "ICPLandmarks",
    "NonrigidICPOptions",
    "NonrigidICPResult",
    "NotDiskError",
    "NotTrianglesError",
    "PointLocation",
    "PointLocator",
    "QiemInfo",
    "QiemOptions",
    "NoInteriorVertexError",
    "ReconstructionInfo",
    "ReconstructionOptions",
    "curvature_direction_normals",
    "normal_update_iteration",
    "ReconstructionOperator",
    "RelaxationInfo",
    "RepeatedFaceIndexError",
    "SeededHole",
    "SelfIntersectingRingError",
    "ShapeError",
    "ShapeRings",
    "SimilarityTransform",
    "SingularSystemError",
    "SphericalMapInfo",
    "SphericalMapOptions",
    "SplineHomotopy",
    "StaticCorrespondenceOptions",
    "StaticCorrespondences",
    "StrainMorphInfo",
    "SurfaceDistance",
    "ThinPlateDeformation",
    "ThinPlateFitInfo",
    "TooFewAnchorsError",
    "UnreferencedVertexError",
    "ZeroAreaFaceError",
    "angle_distortion",
    "arap_interpolation",
    "as_mesh_arrays",
    "available_threads",
    "beltrami_coefficient",
    "boundary_ear_vertices",
    "boundary_isoperimetric_ratio",
    "boundary_loop",
    "boundary_loops",
    "center_on_sphere",
    "check_anchors",
    "compatible_triangulation",
    "DissectionAnchors",
    "checked_paths",
    "cut_polygons",
    "dissection_anchors",
    "glue_patches",
    "outer_boundary_first",
    "HolePairing",
    "seeded_hole_pairing",
    "seed_hole",
    "BoundaryAnchors",
    "boundary_anchors",
    "collapse_slivers",
    "collapse_to_vertex_budget",
    "budgeted_triangulation",
    "mesh_boundary_vertices",
    "relaxed_target",
    "improve_quality",
    "ConsistentBoundary",
    "consistent_boundaries",
    "repair_flips",
    "HoleCuts",
    "check_hole_counts",
    "hole_cuts",
    "PatchMaps",
    "glue_cut",
    "patch_maps",
    "MergedPoints",
    "refined_merged_triangulation",
    "dissect_shapes",
    "dissected_triangulation",
    "conformal_factor",
    "conformal_relaxation",
    "consistent_mesh",
    "corner_angles",
    "corner_edge_products",
    "cotangent_laplacian",
    "cotangent_weights",
    "cross_validate_registration",
    "deformation_gradient",
    "disk_conformal_map",
    "green_disk_map",
    "disk_registration_error",
    "distance_to_rings",
    "double_cover",
    "double_cover_gauss_map",
    "edge_lengths",
    "equator_rotation",
    "even_pace_times",
    "extend_uv_to_ears",
    "factorize",
    "farthest_point_samples",
    "fill_holes",
    "flipped_triangles",
    "fold_correction",
    "fold_free_offsets",
    "fold_region",
    "fold_residual",
    "fold_report",
    "gauss_map",
    "green_lagrange_strain",
    "harmonic_hemisphere_map",
    "hemisphere_to_disk",
    "histogram",
    "interpolate_rotations",
    "interpolate_similarity",
    "interpolate_strain",
    "intrinsic_cotangent_laplacian",
    "intrinsic_cotangents",
    "inverse_stereographic_projection",
    "landmark_disk_mesh",
    "landmark_folds",
    "landmark_rms",
    "linear_interpolation",
    "linear_vertex_frames",
    "locate_points",
    "map_in_threads",
    "map_jacobian_determinants",
    "map_quality",
    "map_stretch",
    "max_orientation_step",
    "mean_curvature",
    "mean_curvature_vector",
    "mean_value_laplacian",
    "mesh_edges",
    "min_triangle_angle",
    "mips_energy",
    "mobius_disk",
    "mobius_registration",
    "morph_frames",
    "morph_metrics_2d",
    "nonrigid_icp",
    "normalize_boundary_to_circle",
    "normalize_by_diameter",
    "normalize_disk_map",
    "overlay_triangle_count",
    "path_steps",
    "point_inside_ring",
    "points_in_ring",
    "points_in_shape",
    "preconditioned_cg",
    "SymmetricRefactorization",
    "prescribed_area_ratio",
    "principal_stretches",
    "projected_barycentrics",
    "qiem_disk_conformal_map",
    "reconstruct_surface",
    "reconstruction_error",
    "reconstruction_operator",
    "refine_angles",
    "refine_disk_mesh",
    "refinement_levels",
    "register_disk_landmarks",
    "remove_boundary_ears",
    "resample_texture",
    "resample_vertex_data",
    "rigid_landmark_alignment",
    "ring_signed_area",
    "rotation_to_quaternion_xyzw",
    "row_blocks",
    "sample_image",
    "seed_missing_holes",
    "shape_function_gradients",
    "signed_areas",
    "signed_areas_2d",
    "signed_corner_angles",
    "spherical_conformal_map",
    "spline_homotopy",
    "static_correspondences",
    "stepwise_thin_plate_registration",
    "stereographic_projection",
    "strain_from_gradient",
    "straight_side_vertices",
    "strain_morph",
    "strain_morph_info",
    "StrainMorphOptions",
    "SolvedFrames",
    "check_strain_morph_options",
    "solve_frame",
    "solve_frames",
    "FrameResult",
    "barrier_newton",
    "continuation_newton",
    "max_positive_step",
    "RigidMotion",
    "gauge_vertices",
    "restore_rigid_motion",
    "rigid_motion",
    "to_gauge",
    "wrap_angle",
    "StrainSystem",
    "strain_target",
    "surface_diameter",
    "surface_registration_error",
    "surface_to_surface_error",
    "symmetric_dirichlet_energy",
    "thin_plate_registration",
    "triangle_areas",
    "triangle_frames",
    "triangulate_polygon",
    "triangulate_segments",
    "triangulate_shape",
    "umeyama_alignment",
    "validate_landmark_pairs",
    "validate_mesh",
    "validate_mesh_elements",
    "validate_rings",
    "vertex_areas",
    "vertex_normals",
    "biharmonic_fill",
    "uniform_laplacian",
    "FilledHoles",
    "fill_holes_faired",
    "hole_patch_faces",
    "patch_rings",
    "ComponentSelection",
    "largest_component",
    "FaceDirection",
    "FaceRegion",
    "FaceRegionError",
    "face_direction",
    "face_region",
    "MeshCleanup",
    "clean_mesh_elements",
    "ManifoldSplit",
    "split_nonmanifold",
    "OrientedFaces",
    "consistent_orientation",
    "LandmarkTolerance",
    "register_disk_landmarks_tolerant",
    "LandmarkSmoothing",
    "discrepancy_smoothing",
    "DetailEmbedding",
    "detail_embedding",
    "transferred_points",
]

sys.modules[__name__].__class__ = LazyPackage
