"""Numerical tolerances, in one place, each with the reason for its value.

All tolerances are relative unless their name says otherwise.
"""

from __future__ import annotations

#: |uv| of a boundary vertex may differ from 1 by at most this much. Boundary
#: vertices are placed as (cos θ, sin θ) and then renormalised, so double
#: precision leaves errors near 1e-16; 1e-9 leaves room for Möbius
#: normalisation round-off.
BOUNDARY_CIRCLE_ATOL = 1e-9

#: A triangle whose area is below this fraction of the mean triangle area is
#: "zero-area". Relative, so that the check does not depend on units (scans in
#: metres and in millimetres are both common).
ZERO_AREA_RTOL = 1e-12

#: A signed 2D triangle area below this fraction of the mean area counts as a
#: flip (negative orientation) in parameterisation checks.
FLIP_AREA_RTOL = 0.0

#: Stopping tolerance of the boundary iteration of the fast disk map: the
#: largest change of a boundary angle, in radians. 1e-10 is far below what
#: changes the interior map measurably (angle distortion changes < 1e-6°).
DISK_MAP_ANGLE_TOL = 1e-10

#: Default relative tolerance of the fixed-point iteration in surface
#: reconstruction (Algorithm 1): max |X^{j+1} - X^j| / bounding-box diagonal.
RECONSTRUCTION_TOL = 1e-9

#: Solutions of linear systems are checked with this relative residual; a
#: larger residual means the factorisation was numerically singular.
SOLVE_RESIDUAL_RTOL = 1e-6

#: Newton–Raphson for strain-field morphing (eq. 11) stops when the Frobenius
#: norm of the position update falls below this fraction of the shape's
#: bounding-box diagonal. Newton converges quadratically near the solution, so
#: the error left after such a step is of the order of its square: on the bar
#: pair the final frame matched the target to 8e-13 (relative 2e-13) with this
#: value, and 1e-7 cost 40% more iterations for no visible change.
STRAIN_NEWTON_STEP_RTOL = 1e-5

#: The frame at t = 1 is solved again to this fraction of ``STRAIN_NEWTON_STEP_RTOL``
#: (1e-9 of the diagonal, far above round-off at ~1e-14): the morph counts as
#: reaching the target only within 1e-6 of the diagonal
#: (``pipelines.morph2d.strain_metrics.TARGET_MATCH_RTOL``), which a step of 1e-5
#: does not ensure where Newton converges slowly (slivers of 1.5°, U → Z).
STRAIN_LAST_FRAME_TOL_FACTOR = 1e-4

#: A strain component counts as changing monotonically over a morph when no
#: step goes against the overall trend by more than this (strain is
#: dimensionless; 1e-6 absorbs Newton round-off, ~1e-12, with a wide margin and
#: is far below a visible change, ~1e-3).
MONOTONE_STRAIN_ATOL = 1e-6

#: Stopping tolerance of the spherical heat flow (QIEM): the largest move of a
#: vertex on the unit sphere in one step. Measured on choi_human_face (harmonic
#: start, lagged scheme, δt = 1): at 1e-4 (9 steps) the disk map's mean angle
#: distortion equals the value at 1e-7 (15 steps) to four digits.
SPHERE_MAP_STEP_TOL = 1e-4

#: Newton on the MIPS energy (:func:`conformorph.geometry.conformal_relaxation`) stops when a
#: step lowers the energy by less than this fraction. Measured on the ICT
#: mouth-corner folds: the mean angle distortion of the repaired map stops
#: changing in its fourth digit below 1e-6, reached in 10–20 steps.
RELAXATION_ENERGY_RTOL = 1e-6

#: The relaxation of a compatible map's target
#: (:func:`conformorph.geometry.compatible_map_relaxation.relaxed_target`) stops when a
#: Newton step lowers the symmetric Dirichlet energy by less than this fraction. On
#: horse → chair, B → C, horse → star, star → horse and U → Z without anchors the
#: energy falls 1.6–20-fold in the first 10–20 steps, then by under 0.5 % in the next
#: 40–70 (0.5–2 s of Newton steps at 460–600 vertices). With the uniform scale in the
#: strain morph (eq. 2/3) horse → chair (the chair 0.29 of the horse's area) reached the
#: target at 1e-6 and 1e-5 but not at 1e-4 or 1e-3; with the scale taken out
#: (:func:`conformorph.pipelines.morph2d.strain_interpolation.scale_separated_strain_morph`)
#: it reaches it at 1e-3 and 1e-5, and all 19 anchor-free benchmark pairs do at 1e-3.
TARGET_RELAX_ENERGY_RTOL = 1e-3

#: Two anchors closer than this fraction of their shape's bounding-box
#: diagonal are the same point: one point cannot be pinned to two places (the
#: compatible triangulation's merged points coincide and its solve is exactly
#: singular). Relative, and well above round-off (1e-16) and the 3–6 digits
#: anchors are usually written with, so only real duplicates are refused.
ANCHOR_COINCIDENT_RTOL = 1e-6

#: The strain morph's orientation barrier (``solver="barrier"`` of
#: :func:`conformorph.geometry.strain_morph`) starts to act when a triangle's area ratio falls
#: below this fraction of the ratio its interpolated strain prescribes: far from
#: every frame of a morph that stays unfolded by itself (the bar pair's areas stay
#: within 5 % of the prescribed path), so there the result is eq. (9)'s exactly.
#: Acting early also steadies the path where the interpolated strains are far
#: from compatible: horse -> star (2673 vertices, eq. 3 in the principal frame,
#: 61 frames) with 0.25 took 50-250 Newton iterations per frame from t = 0.3 on
#: and stalled at t = 0.63 (3000 iterations; at t = 0.85 with no limit); with
#: 0.7, 3-12 per frame up to t = 0.8 and the target in 2551 in all (0.5 stalled
#: at t = 0.73, 0.75 reached it in 3483, 0.8 and 0.9 stalled at 0.93 and 0.92:
#: the last frames are sensitive to it).
STRAIN_BARRIER_FRACTION = 0.7

#: Weight of that barrier relative to the strain energy W (both are integrals
#: over the source area of dimensionless densities).
STRAIN_BARRIER_WEIGHT = 1.0

#: Largest time step of the strain morph's solver (requested frames further
#: apart get intermediate warm-start frames). The paths of W's minimisers
#: branch: on the stick-figure pair 5 requested frames (steps of 1/4) led the
#: principal scheme to a branch ending 0.8 % of the target's size from it, while
#: steps of 1/60 reached the target to 8e-11; 1/60 is also the step of the
#: benchmarks' 61-frame morphs, on which every committed pair was measured.
STRAIN_MAX_TIME_STEP = 1.0 / 60.0

#: Relative slack of the strain morph's total-area bound: a frame's prescribed total
#: area may leave the range of the end frames' by this fraction before its strain is
#: dilated back (:func:`conformorph.geometry.strain_targets.strain_target`). Eq. (2)
#: on the bar pair (area kept, bent) leaves it by round-off-sized amounts that need
#: no correction; the swelling of eq. (3) is tens of percent (L → T: 0.33).
STRAIN_AREA_SLACK = 1e-2

#: A seed hole (:func:`geometry.seed_missing_holes`) takes this fraction of the
#: room (distance to the nearest ring) around its centre: small enough to read as
#: a dot at t = 0, large enough that its triangles are not slivers (the strain
#: morph's area ratios near it grow as the square of hole radius over seed radius).
HOLE_SEED_RADIUS_FRACTION = 0.3

#: Levenberg–Marquardt of the reconstruction's fold correction
#: (:func:`conformorph.geometry.fold_correction`) stops when a step lowers the residual by
#: less than this fraction. Measured on ICT pucker and sad: the L∞ error reaches
#: its floor (2.0e-3, the level of faces whose disk map does not fold) while
#: steps still lower the residual by several per cent.
FOLD_CORRECTION_RTOL = 1e-3

#: Crease scale of the face cut (:func:`conformorph.geometry.face_region`), radians: an edge
#: whose faces' normals differ by θ weighs exp(-(θ/30°)²) of its length. A 10° fold of a
#: smooth scan keeps 90 % of its weight, a 60° seam (a face glued onto a head) under 2 %, so
#: the cut follows seams and folds where they exist and is merely short elsewhere.
FACE_CUT_CREASE_ANGLE = 0.5235987755982988

#: Weight left to an edge on the sharpest crease, as a fraction of its length: keeps every
#: capacity of the cut positive (a zero-capacity edge would make the cut arbitrary there).
FACE_CUT_CAPACITY_FLOOR = 1e-3

#: Extra weight, per unit length, of cutting next to the face's core rather than at the
#: reach (:func:`conformorph.geometry.face_region._outward_push`): on a smooth head the
#: shortest loop would hug the landmarks' hull; a crease still wins (0.06 of its length at
#: 50° against 1 + push at most).
FACE_CUT_PUSH = 1.0

#: ``reach`` of :func:`conformorph.geometry.face_region` with landmarks: times their RMS
#: size in the frontal plane (0.62 inter-ocular distances for the 68-point layout: the
#: region ends about 0.75 of them above the brows, at the hairline; the ICT face's outline
#: lies at most 0.74 from its landmarks).
FACE_CUT_REACH_LANDMARKS = 1.2

#: ``reach`` without landmarks: times the shape core's radius (0.4 of the head's width).
#: Measured on the ICT face closed into a head: 1.2 cut into the face, 1.35 kept all of it.
FACE_CUT_REACH_SHAPE = 1.35

#: Flattening tolerance of SVG curves and stroke outlines, as a fraction of the drawing's
#: diagonal (:mod:`conformorph.pipelines.svg_path`): a 24-unit icon's curves stay within
#: 0.034 units of their chords (a circle of radius 10 gets 38 sides); the working
#: resolution (100 points by default) is far coarser, so the morph does not see it.
SVG_FLATTEN_RTOL = 1e-3

#: Two rings of a 2D shape (or two stretches of one ring) closer than this fraction of
#: the shape's extent touch: a vertex on another ring's edge up to rounding (SVG
#: transforms and arc flattening leave 1e-15 of the extent). Triangle then merges the
#: two boundaries there, and no mesh with separate boundary loops exists.
RING_TOUCH_RTOL = 1e-9

#: How far such a touching vertex is moved to part the rings, as a fraction of the
#: shape's extent (and at most a quarter of its shortest edge): 1/1000 of the size,
#: below a pixel at 1000 pixels, wide enough for a mesh of fair triangles.
RING_PART_GAP = 1e-3

#: A touching vertex whose narrower angle is wider than this (degrees) is a stretch of
#: boundary that another ring's tip touches, not a tip itself, and is not moved: its
#: narrower side is a slight bend that may face the tip (an icon's outline measured
#: 175.7° where a 46.9° spike of the same ring touched it).
RING_TIP_MAX_ANGLE = 170.0
