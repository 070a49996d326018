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

from conformorph.geometry._lazy_exports import LazyPackage, export_owners

if TYPE_CHECKING:
    from .angle_distortion import angle_distortion, corner_angles, corner_edge_products
    from .angle_refinement import AngleRefinementInfo, refine_angles, signed_corner_angles
    from .arap_interpolation import arap_interpolation
    from .assignment import min_cost_assignment
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
    from .detail_transfer import (
        DetailEmbedding,
        detail_embedding,
        transferred_frames,
        transferred_points,
    )
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
    from .interval_sweep import x_overlap_pairs
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
    from .map_fold_repair import MapFoldRepair, map_fold_repair
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
    from .sampled_surface_error import sampled_surface_l2
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
        winding_numbers,
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
    from .touching_rings import part_touching_rings
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
    from .vertex_normals import VertexNormals, vertex_normals
    from .vertex_pull import MutualNearestVertices, VertexPairs


#: every name the imports above re-export, read from them (one list, not two to keep equal)
__all__ = list(export_owners(__file__))

sys.modules[__name__].__class__ = LazyPackage
