"""The reference points of the rigid-motion removal (the paper's main steps 1 and 5).

:func:`conformorph.geometry.strain_morph.strain_morph` removes the rotation and translation
between source and target through two points A (translation) and B (rotation)
inside the source, and puts the interpolated motion back on every frame
(:mod:`conformorph.geometry.strain_rigid_motion`). The pipeline takes them from the anchors.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray


def reference_points(anchors: NDArray[np.float64]) -> NDArray[np.float64]:
    """A⁰ and B⁰: the source points of the first two anchors.

    Parameters
    ----------
    anchors : (a, 2, 2) float64
        Anchor pairs ``[source point, target point]``, a ≥ 2.

    Returns
    -------
    (2, 2) float64
        ``[A⁰, B⁰]``; their target positions follow from the compatible meshes.
    """
    return anchors[:2, 0]
