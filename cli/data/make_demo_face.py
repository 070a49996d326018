"""Provenance of ``demo_face.obj`` (run to regenerate; needs ../shared/data/faces).

Source: ``meshmonk_Template.obj`` = TheWebMonks/meshmonk ``data/Template.obj``
(commit 7debc59a, Apache-2.0, "Copyright 2017 WebMonks"), 7160 vertices.

Steps, all deterministic:

1. keep the triangles whose three vertices lie within 60 mm (3D distance) of
   the nose-tip vertex 3767;
2. repeat until nothing changes: keep the largest edge-connected component,
   drop triangles that have all three vertices on the boundary or that hold a
   boundary "ear" vertex (in one triangle only);
3. drop unreferenced vertices (the kept vertices stay in their source order)
   and move the face so that its area-weighted centroid is at the origin.

The result is a disk of about 2.6k vertices.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from conformorph.geometry.boundary_loop import boundary_loops
from conformorph.geometry.validate_mesh import boundary_ear_vertices, triangle_areas, validate_mesh
from conformorph.pipelines.mesh_io import read_mesh

SOURCE = Path(__file__).resolve().parents[3] / "shared" / "data" / "faces" / "meshmonk_Template.obj"
NOSE_TIP = 3767
RADIUS_MM = 60.0


def demo_face() -> tuple[np.ndarray, np.ndarray]:
    """The cropped face, (V (n,3) float64, F (m,3) int64)."""
    V, F = read_mesh(SOURCE)
    near = np.linalg.norm(V - V[NOSE_TIP], axis=1) < RADIUS_MM
    F = F[near[F].all(axis=1)]
    while True:
        A = sp.coo_array(
            (np.ones(F.size), (np.repeat(np.arange(F.shape[0]), 3), F.reshape(-1))),
            shape=(F.shape[0], V.shape[0]),
        ).tocsr()
        _, label = connected_components(A @ A.T)
        keep = label == np.argmax(np.bincount(label))
        on_b = np.zeros(V.shape[0], dtype=bool)
        for loop in boundary_loops(F[keep]):
            on_b[loop] = True
        keep &= ~on_b[F].all(axis=1)
        keep &= ~np.isin(F, boundary_ear_vertices(F[keep])).any(axis=1)
        if keep.all():
            break
        F = F[keep]
    used = np.unique(F)
    remap = np.full(V.shape[0], -1, dtype=np.int64)
    remap[used] = np.arange(used.size)
    V, F = V[used], remap[F]
    a = triangle_areas(V, F)
    V = V - (a[:, None] * V[F].mean(axis=1)).sum(axis=0) / a.sum()
    validate_mesh(V, F, require_disk=True)
    return V, F


if __name__ == "__main__":
    V, F = demo_face()
    out = Path(__file__).with_name("demo_face.obj")
    lines = [
        "# demo_face: cropped MeshMonk template (Apache-2.0); see make_demo_face.py and README.md"
    ]
    lines += [f"v {a:.6f} {b:.6f} {c:.6f}" for a, b, c in V]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in F]
    out.write_text("\n".join(lines) + "\n")
    print(f"{out}: {V.shape[0]} vertices, {F.shape[0]} faces")
