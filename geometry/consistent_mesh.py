"""Consistent meshes on the disk and resampling of per-vertex data (section 4 of the face paper).

"First, a coarse mesh is constructed by connecting the landmarks on the unit
disk using straight line segments on φ0(M0). Then a finer mesh is obtained by
regular mesh refinements for a few times." The nodes of that mesh are carried
to the other disks by the registration maps, and every per-vertex quantity
(H, λ, positions, colours, UVs) of an input mesh is resampled at the carried
nodes by barycentric interpolation in that input's disk map — so the inputs
never need to share connectivity. Texture images are resampled the same way,
texel by texel (:func:`resample_texture`): every key's texture is rendered on
one UV layout of the consistent mesh.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import Delaunay

from ._typing import BoolArray, FloatArray, IntArray
from .boundary_loop import boundary_loop
from .flipped_triangles import signed_areas_2d
from .mesh_edges import mesh_edges
from .point_location import PointLocator

#: Two landmarks closer than this on the disk are duplicates (the coarse mesh
#: would get a degenerate triangle).
LANDMARK_MIN_SEPARATION = 1e-6


@dataclass(frozen=True)
class ConsistentMesh:
    """A triangulation of the source disk shared by all key frames.

    Attributes
    ----------
    uv : (n, 2) float64
        Node positions on the source disk :math:`\\varphi_0(M_0)`.
    F : (m, 3) int64
        Counter-clockwise triangles.
    b : (k,) int64
        Boundary loop (nodes on the unit circle), oriented like F.
    levels : int
        Regular refinements applied to the coarse landmark mesh (0 for the
        source-mesh mode).
    mode : str
        ``"landmarks"`` or ``"source"``.
    """

    uv: FloatArray
    F: IntArray
    b: IntArray
    levels: int
    mode: str


def landmark_disk_mesh(
    landmarks_uv: FloatArray, *, n_boundary: int = 32
) -> tuple[FloatArray, IntArray]:
    """Coarse triangulation of the unit disk connecting the landmarks.

    Parameters
    ----------
    landmarks_uv : (m, 2) float64
        Landmarks strictly inside the unit disk.
    n_boundary : int, default 32
        Nodes placed evenly on the unit circle (angle 0 first).

    Returns
    -------
    uv : (m + n_boundary, 2) float64
        The landmarks first (in their order), then the circle nodes.
    F : (f, 3) int64
        Delaunay triangles, counter-clockwise.

    Raises
    ------
    ValueError
        If a landmark is not strictly inside the disk or two landmarks coincide.
    """
    P = np.asarray(landmarks_uv, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 2 or P.shape[0] < 1 or not np.all(np.isfinite(P)):
        raise ValueError(f"landmarks_uv must be a finite (m, 2) array, got {P.shape}")
    if n_boundary < 3:
        raise ValueError(f"n_boundary must be ≥ 3, got {n_boundary}")
    if np.any(np.hypot(P[:, 0], P[:, 1]) >= 1.0 - 1e-9):
        raise ValueError("landmarks must lie strictly inside the unit disk")
    d = np.linalg.norm(P[:, None] - P[None], axis=2) + np.eye(P.shape[0])
    if d.min() < LANDMARK_MIN_SEPARATION:
        i, j = np.unravel_index(np.argmin(d), d.shape)
        raise ValueError(f"landmarks {i} and {j} coincide on the disk")
    ang = 2 * np.pi * np.arange(n_boundary) / n_boundary
    uv = np.vstack([P, np.c_[np.cos(ang), np.sin(ang)]])
    F = np.asarray(Delaunay(uv).simplices, dtype=np.int64)
    a = signed_areas_2d(uv, F)
    F[a < 0] = F[a < 0][:, [0, 2, 1]]
    F = F[np.abs(a) > 1e-14]
    return uv, F


def refine_disk_mesh(uv: FloatArray, F: IntArray, levels: int) -> tuple[FloatArray, IntArray]:
    """Regular (1 → 4) refinement of a disk triangulation, boundary midpoints put on the circle.

    Parameters
    ----------
    uv : (n, 2) float64
        Nodes; boundary nodes on the unit circle.
    F : (m, 3) int64
        Counter-clockwise triangles of a disk.
    levels : int
        Number of refinements (≥ 0).

    Returns
    -------
    uv : (n', 2) float64
        The old nodes first (same order), then edge midpoints.
    F : (4^levels m, 3) int64
    """
    if levels < 0:
        raise ValueError(f"levels must be ≥ 0, got {levels}")
    uv = np.asarray(uv, dtype=np.float64).copy()
    F = np.asarray(F, dtype=np.int64).copy()
    for _ in range(levels):
        E = mesh_edges(F)
        n = uv.shape[0]
        mid = 0.5 * (uv[E.edges[:, 0]] + uv[E.edges[:, 1]])
        on_b = E.face_count == 1
        mid[on_b] /= np.linalg.norm(mid[on_b], axis=1, keepdims=True)
        uv = np.vstack([uv, mid])
        e = n + E.halfedge_edge  # (m, 3): midpoint of edge (F[:, j], F[:, j+1])
        a, b_, c = F[:, 0], F[:, 1], F[:, 2]
        ab, bc, ca = e[:, 0], e[:, 1], e[:, 2]
        F = np.vstack(
            [np.c_[a, ab, ca], np.c_[ab, b_, bc], np.c_[ca, bc, c], np.c_[ab, bc, ca]]
        ).astype(np.int64)
    return uv, F


def refinement_levels(n_coarse_vertices: int, n_coarse_faces: int, target_vertices: int) -> int:
    """Smallest number of regular refinements giving at least ``target_vertices`` nodes.

    Parameters
    ----------
    n_coarse_vertices, n_coarse_faces : int
        Size of the coarse disk mesh.
    target_vertices : int
        Requested resolution.

    Returns
    -------
    int

    Notes
    -----
    For a disk, V − E + F = 1, so E = V + F − 1; one refinement gives
    V' = V + E and F' = 4F.
    """
    v, f, k = n_coarse_vertices, n_coarse_faces, 0
    while v < target_vertices and k < 12:
        v, f, k = v + (v + f - 1), 4 * f, k + 1
    return k


def consistent_mesh(
    source_uv: FloatArray,
    source_F: IntArray,
    landmarks_uv: FloatArray,
    *,
    mode: str = "landmarks",
    target_vertices: int | None = None,
    levels: int | None = None,
    n_boundary: int = 32,
) -> ConsistentMesh:
    """Build the consistent mesh on the source disk.

    Parameters
    ----------
    source_uv : (n0, 2) float64
        Disk map of the source surface.
    source_F : (m0, 3) int64
        Its triangles.
    landmarks_uv : (m, 2) float64
        Source landmarks on the disk.
    mode : {"landmarks", "source"}, default "landmarks"
        ``"landmarks"``: the paper's coarse mesh connecting the landmarks (plus
        ``n_boundary`` circle nodes), refined ``levels`` times; ``"source"``:
        the source disk mesh itself.
    target_vertices : int, optional
        With ``mode="landmarks"`` and no ``levels``: refine until at least this
        many nodes (default: the source vertex count).
    levels : int, optional
        Explicit number of refinements.
    n_boundary : int, default 32
        Circle nodes of the coarse mesh.

    Returns
    -------
    ConsistentMesh
    """
    src_uv = np.asarray(source_uv, dtype=np.float64)
    src_F = np.asarray(source_F, dtype=np.int64)
    if mode == "source":
        return ConsistentMesh(src_uv.copy(), src_F.copy(), boundary_loop(src_F), 0, "source")
    if mode != "landmarks":
        raise ValueError(f"mode must be 'landmarks' or 'source', got {mode!r}")
    uv, F = landmark_disk_mesh(landmarks_uv, n_boundary=n_boundary)
    if levels is None:
        tv = src_uv.shape[0] if target_vertices is None else int(target_vertices)
        levels = refinement_levels(uv.shape[0], F.shape[0], tv)
    uv, F = refine_disk_mesh(uv, F, levels)
    return ConsistentMesh(uv, F, boundary_loop(F), int(levels), "landmarks")


def resample_vertex_data(
    disk_uv: FloatArray,
    F: IntArray,
    values: FloatArray,
    points: FloatArray,
    *,
    locator: PointLocator | None = None,
) -> FloatArray:
    """Resample per-vertex data of a disk-parameterised mesh at points of its disk.

    Parameters
    ----------
    disk_uv : (n, 2) float64
        Disk map of the mesh the data lives on.
    F : (m, 3) int64
        Its triangles.
    values : (n,) or (n, d) float64
        Per-vertex data (H, λ, 3D positions, colours, UVs, ...).
    points : (p, 2) float64
        Where to sample (e.g. consistent-mesh nodes carried by a registration map).
    locator : PointLocator, optional
        Prepared locator for (disk_uv, F), reused if given.

    Returns
    -------
    (p,) or (p, d) float64
        Barycentric interpolation (points outside the polygonal disk are
        snapped to its nearest point).
    """
    vals = np.asarray(values, dtype=np.float64)
    if vals.shape[0] != np.asarray(disk_uv).shape[0]:
        raise ValueError(
            f"values have {vals.shape[0]} rows, disk_uv has {np.asarray(disk_uv).shape[0]}"
        )
    loc = (locator or PointLocator(disk_uv, F)).locate(points)
    return loc.interpolate(np.asarray(F, dtype=np.int64), vals)


#: texel–triangle candidate pairs examined at once by :func:`resample_texture`
_RASTER_CHUNK = 1 << 22


def _rasterize(px: FloatArray, F: IntArray, shape: tuple[int, int]) -> tuple[IntArray, FloatArray]:
    """Triangle and barycentric coordinates of every texel centre covered by a 2D mesh.

    ``px`` are vertex positions in texel units (x right, y down; texel (r, c)
    has its centre at (c + 0.5, r + 0.5)). Returns ``tri (H, W)`` (−1 where
    no triangle covers the centre) and ``bary (H, W, 3)``.
    """
    H, W = shape
    tri_map = np.full((H, W), -1, dtype=np.int64)
    bary_map = np.zeros((H, W, 3))
    corners = px[F]  # (m, 3, 2)
    lo = np.ceil(corners.min(axis=1) - 0.5).astype(np.int64)
    hi = np.floor(corners.max(axis=1) - 0.5).astype(np.int64)
    lo = np.maximum(lo, 0)
    hi = np.minimum(hi, [W - 1, H - 1])
    nx = np.maximum(hi[:, 0] - lo[:, 0] + 1, 0)
    ny = np.maximum(hi[:, 1] - lo[:, 1] + 1, 0)
    count = nx * ny
    a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
    det = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    count[np.abs(det) <= 1e-12] = 0  # degenerate in the layout: covers nothing
    ends = np.cumsum(count)
    start = 0
    while start < F.shape[0]:
        # triangles [start, stop) hold at most _RASTER_CHUNK candidate texels (≥ 1 triangle)
        base = ends[start - 1] if start else 0
        stop = max(int(np.searchsorted(ends, base + _RASTER_CHUNK, side="right")), start + 1)
        t = np.repeat(np.arange(start, stop), count[start:stop])
        if t.size:
            first = np.repeat(ends[start:stop] - count[start:stop] - base, count[start:stop])
            local = np.arange(t.size) - first
            col = lo[t, 0] + local % nx[t]
            row = lo[t, 1] + local // nx[t]
            x = np.c_[col + 0.5, row + 0.5]
            v0, v1, v2 = b[t] - a[t], c[t] - a[t], x - a[t]
            l1 = (v2[:, 0] * v1[:, 1] - v2[:, 1] * v1[:, 0]) / det[t]
            l2 = (v0[:, 0] * v2[:, 1] - v0[:, 1] * v2[:, 0]) / det[t]
            lam = np.c_[1.0 - l1 - l2, l1, l2]
            inside = (lam >= -1e-9).all(axis=1)
            tri_map[row[inside], col[inside]] = t[inside]
            w = np.clip(lam[inside], 0.0, None)
            bary_map[row[inside], col[inside]] = w / w.sum(axis=1, keepdims=True)
        start = stop
    return tri_map, bary_map


def sample_image(image: FloatArray, uv: FloatArray) -> FloatArray:
    """Bilinear samples of an image at texture coordinates.

    Parameters
    ----------
    image : (h, w, c) float64
        Texel values; row 0 is the image's top.
    uv : (p, 2) float64
        Texture coordinates, origin at the image's bottom-left corner (OBJ /
        OpenGL convention, v up); (0, 0) and (1, 1) are the outer corners of
        the corner texels. Outside [0, 1]² the edge texels are repeated
        (clamp to edge).

    Returns
    -------
    (p, c) float64

    Examples
    --------
    >>> import numpy as np
    >>> img = np.array([[[0.0], [1.0]], [[2.0], [3.0]]])  # 2 × 2, top row 0, 1
    >>> sample_image(img, np.array([[0.5, 0.5], [0.25, 0.75]]))[:, 0].tolist()
    [1.5, 0.0]
    """
    img = np.asarray(image, dtype=np.float64)
    if img.ndim != 3 or min(img.shape[:2]) < 1:
        raise ValueError(f"image must have shape (h, w, c), got {img.shape}")
    q = np.asarray(uv, dtype=np.float64)
    if q.ndim != 2 or q.shape[1] != 2 or not np.all(np.isfinite(q)):
        raise ValueError(f"uv must be a finite (p, 2) array, got {q.shape}")
    h, w = img.shape[:2]
    x = np.clip(q[:, 0] * w - 0.5, 0.0, w - 1.0)
    y = np.clip((1.0 - q[:, 1]) * h - 0.5, 0.0, h - 1.0)
    x0 = np.minimum(np.floor(x).astype(np.int64), w - 1)
    y0 = np.minimum(np.floor(y).astype(np.int64), h - 1)
    x1 = np.minimum(x0 + 1, w - 1)
    y1 = np.minimum(y0 + 1, h - 1)
    fx = (x - x0)[:, None]
    fy = (y - y0)[:, None]
    return np.asarray(
        img[y0, x0] * (1 - fx) * (1 - fy)
        + img[y0, x1] * fx * (1 - fy)
        + img[y1, x0] * (1 - fx) * fy
        + img[y1, x1] * fx * fy
    )


def resample_texture(
    layout_uv: FloatArray,
    F: IntArray,
    source_uv: FloatArray,
    image: FloatArray,
    shape: tuple[int, int],
) -> tuple[FloatArray, BoolArray]:
    """Render a texture onto another UV layout of corresponding mesh points.

    Every texel centre q of the output is located in the triangle of
    ``(layout_uv, F)`` that covers it; the point of the source image it shows
    is the same barycentric combination of that triangle's ``source_uv``,
    sampled bilinearly. With ``layout_uv`` the texture coordinates of the
    consistent mesh and ``source_uv`` the texture coordinates of key i
    resampled at the consistent nodes (through the composite registration
    map), this is the paper's :math:`I_0(\\varphi_0^{-1}(q)) \\mapsto
    I_i(\\varphi_i^{-1} \\circ \\bar f(q))`, with the composite map taken
    linear on each consistent-mesh triangle.

    Parameters
    ----------
    layout_uv : (n, 2) float64
        Texture coordinates of the mesh vertices in the output texture (OBJ
        convention, origin bottom left, see :func:`sample_image`).
    F : (m, 3) int64
        Triangles (either orientation).
    source_uv : (n, 2) float64
        Texture coordinates of the same vertices in ``image``.
    image : (h, w, c) float64
        The texture to resample.
    shape : (H, W)
        Output size in texels.

    Returns
    -------
    texture : (H, W, c) float64
        The resampled texture. Texels no triangle covers take the value of
        the nearest covered texel (padding, so that filtering and mipmaps
        near chart edges do not pull in unrelated colour).
    covered : (H, W) bool
        Texels whose centre some triangle covers.

    Raises
    ------
    ValueError
        Wrong shapes, non-finite coordinates, face indices out of range, or
        a layout that covers no texel centre.
    """
    from scipy.ndimage import distance_transform_edt

    L = np.asarray(layout_uv, dtype=np.float64)
    S = np.asarray(source_uv, dtype=np.float64)
    Fa = np.asarray(F, dtype=np.int64)
    if L.ndim != 2 or L.shape[1] != 2 or S.shape != L.shape:
        raise ValueError(
            f"layout_uv and source_uv must both be (n, 2), got {L.shape} and {S.shape}"
        )
    if not (np.all(np.isfinite(L)) and np.all(np.isfinite(S))):
        raise ValueError("layout_uv and source_uv must be finite")
    if Fa.ndim != 2 or Fa.shape[1] != 3 or Fa.shape[0] == 0:
        raise ValueError(f"F must have shape (m, 3) with m ≥ 1, got {Fa.shape}")
    if Fa.min() < 0 or Fa.max() >= L.shape[0]:
        raise ValueError(f"F indexes vertices outside 0..{L.shape[0] - 1}")
    H, W = (int(x) for x in shape)
    if H < 1 or W < 1:
        raise ValueError(f"shape must be two positive sizes, got {shape}")
    img = np.asarray(image, dtype=np.float64)
    if img.ndim != 3:
        raise ValueError(f"image must have shape (h, w, c), got {img.shape}")
    px = np.c_[L[:, 0] * W, (1.0 - L[:, 1]) * H]
    tri, bary = _rasterize(px, Fa, (H, W))
    covered = tri >= 0
    if not covered.any():
        raise ValueError("the layout covers no texel centre of the output texture")
    rows, cols = np.nonzero(covered)
    t = tri[rows, cols]
    src = np.einsum("pj,pjk->pk", bary[rows, cols], S[Fa[t]])
    out = np.zeros((H, W, img.shape[2]))
    out[rows, cols] = sample_image(img, src)
    if not covered.all():
        idx = distance_transform_edt(~covered, return_distances=False, return_indices=True)
        out = out[idx[0], idx[1]]
    return out, covered
