"""Automatic face landmarks (issue 16): the Multi-PIE 68 points of a face mesh, no clicks.

:func:`detect_landmarks` (in :mod:`.detect`) renders the mesh by ray casting
(:mod:`.render`), chooses a frontal view (:mod:`.frontal_view`), runs MediaPipe
FaceMesh (:mod:`.mediapipe_detector`), maps its 478 points to the Multi-PIE 68
(:mod:`.multipie68`, a committed table) and casts one ray per landmark back onto
the surface. Failures are named (:mod:`.detection_errors`).

Needs the optional packages ``mediapipe==0.10.14`` and ``embreex``; importing
this package does not.
"""
