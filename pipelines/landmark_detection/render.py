"""Ray-cast orthographic rendering of a mesh, with the triangle and barycentric of every pixel.

A landmark found in the image (a sub-pixel position) maps back onto the surface
exactly: one ray through that position gives its triangle and barycentric
coordinates (:func:`surface_points_at_pixels`). Shading is grey Lambert with the
light at the camera on a black background, the picture a face detector expects
from a plaster cast. Shading uses float64 barycentrics (not Embree's float32
ones), so that a rotated copy of a mesh renders to the same image: FaceMesh
answers differently to one grey level changed here and there (measured: up to
1 mm on choi_human_face with float32 shading, 0.000 mm with float64).

Camera convention: ``rotation`` rows are the camera's right, up and backward
axes in world coordinates (a right-handed frame); the camera looks along
``-rotation[2]``. Pixel ``(x, y)`` has ``x`` to the right and ``y`` down; pixel
centres are at integer + 0.5.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from conformorph.geometry.vertex_normals import vertex_normals


class RayCastingUnavailableError(ImportError):
    """Embree's ray caster (the ``embreex`` package) is not installed."""


@dataclass(frozen=True)
class OrthographicCamera:
    """An orthographic camera looking at the mesh.

    Attributes
    ----------
    rotation : (3, 3) float64
        Rows: right, up and backward (towards the viewer) unit vectors, det +1.
    center : (3,) float64
        World point seen at the image centre.
    pixel_size : float
        World length of one pixel.
    size : int
        The image is ``size`` × ``size`` pixels.
    """

    rotation: NDArray[np.float64]
    center: NDArray[np.float64]
    pixel_size: float
    size: int

    def project(self, points: NDArray[np.float64]) -> NDArray[np.float64]:
        """Pixel positions ``(x, y)`` of world points, shape (n, 2)."""
        c = (np.asarray(points, dtype=np.float64) - self.center) @ self.rotation.T
        half = 0.5 * self.size
        return np.column_stack([half + c[:, 0] / self.pixel_size, half - c[:, 1] / self.pixel_size])

    def depth(self, points: NDArray[np.float64]) -> NDArray[np.float64]:
        """Distance towards the viewer along the backward axis, shape (n,) (larger is nearer)."""
        return (np.asarray(points, dtype=np.float64) - self.center) @ self.rotation[2]

    def rays(self, pixels: NDArray[np.float64], start: float) -> tuple[
        NDArray[np.float64], NDArray[np.float64]
    ]:
        """Ray origins (n, 3) at depth ``start`` through ``pixels`` (n, 2), and directions (n, 3)."""
        p = np.asarray(pixels, dtype=np.float64).reshape(-1, 2)
        half = 0.5 * self.size
        cx = (p[:, 0] - half) * self.pixel_size
        cy = (half - p[:, 1]) * self.pixel_size
        R = self.rotation
        origins = self.center + cx[:, None] * R[0] + cy[:, None] * R[1] + start * R[2]
        directions = np.tile(-R[2], (p.shape[0], 1))
        return origins, directions

    def rolled(self, angle: float) -> OrthographicCamera:
        """The camera turned by ``angle`` radians about its viewing axis (image turns by -angle)."""
        c, s = np.cos(angle), np.sin(angle)
        R = self.rotation
        right = c * R[0] + s * R[1]
        up = -s * R[0] + c * R[1]
        return OrthographicCamera(np.vstack([right, up, R[2]]), self.center, self.pixel_size, self.size)


@dataclass(frozen=True)
class Render:
    """One rendered view.

    Attributes
    ----------
    camera : OrthographicCamera
    image : (size, size) uint8
        Grey Lambert shading, 0 where no ray hit.
    triangle : (size, size) int64
        Triangle hit at each pixel centre, -1 where none.
    barycentric : (size, size, 3) float64
        Barycentric coordinates of the hit in its triangle (0 where none).
    depth : (size, size) float64
        Depth of the hit (``camera.depth``), -inf where none.
    """

    camera: OrthographicCamera
    image: NDArray[np.uint8]
    triangle: NDArray[np.int64]
    barycentric: NDArray[np.float64]
    depth: NDArray[np.float64]

    def rgb(self) -> NDArray[np.uint8]:
        """The image as (size, size, 3) uint8 RGB, contiguous."""
        return np.ascontiguousarray(np.repeat(self.image[:, :, None], 3, axis=2))


@dataclass(frozen=True)
class SurfaceHits:
    """Where rays through image positions meet the surface (the nearest hit of each).

    Attributes
    ----------
    hit : (n,) bool
        False where the ray missed the mesh (background or a hole).
    triangle : (n,) int64
        Triangle hit, -1 where none.
    barycentric : (n, 3) float64
    points : (n, 3) float64
        Hit positions (nan where none).
    """

    hit: NDArray[np.bool_]
    triangle: NDArray[np.int64]
    barycentric: NDArray[np.float64]
    points: NDArray[np.float64]


class _EmbreeScene:
    """An Embree scene of one mesh (the ``embreex`` package), queried in float32.

    Embree works in float32, so the mesh is shifted to its lowest corner and scaled to a
    bounding-box diagonal of 100 first, and every ray's origin with it (as trimesh's
    ``RayMeshIntersector`` does, whose scene this was before: the same float32 inputs,
    the same hits). embreex is used directly: a ``--landmarks auto`` process that detects
    no longer imports trimesh, and two ICT faces with a cold key cache went from 3.05 s to
    2.89 s whole process (medians of 5, interleaved).
    """

    def __init__(self, V: NDArray[np.float64], F: NDArray[np.int64]) -> None:
        try:
            from embreex import rtcore_scene
            from embreex.mesh_construction import TriangleMesh
        except ImportError:
            raise RayCastingUnavailableError(
                "landmark detection needs the embreex package: run scripts/install_landmarks.sh"
            ) from None
        used = np.zeros(V.shape[0], dtype=bool)
        used[F.ravel()] = True
        extents = np.ptp(V[used], axis=0) if used.any() else np.zeros(3)
        diagonal = float((extents**2).sum() ** 0.5)
        self.scale = 100.0 / diagonal if diagonal >= 1e-13 else 100.0
        self.origin = V.min(axis=0)
        self.scene = rtcore_scene.EmbreeScene()
        TriangleMesh(
            scene=self.scene,
            vertices=((V - self.origin) * self.scale).astype(np.float32),
            indices=F.astype(np.int32),
        )

    def run(self, origins: NDArray[np.float64], directions: NDArray[np.float64]) -> Any:
        """First hits of the rays (embreex's ``output=1`` record: geomID, primID, u, v, tfar)."""
        o = ((origins - self.origin) * self.scale).astype(np.float32)
        return self.scene.run(o, directions.astype(np.float32), output=1)


class MeshRayCaster:
    """Embree ray casting on one mesh, built once and used for every view.

    Parameters
    ----------
    V : (n, 3) float64
    F : (m, 3) int64

    Raises
    ------
    RayCastingUnavailableError
        ``embreex`` is not installed (a pure-Python caster is too slow here).
    """

    def __init__(self, V: NDArray[np.float64], F: NDArray[np.int64]) -> None:
        self.V = np.asarray(V, dtype=np.float64)
        self.F = np.asarray(F, dtype=np.int64)
        self._scene = _EmbreeScene(self.V, self.F)
        self.normals = vertex_normals(self.V, self.F)
        lo, hi = self.V.min(axis=0), self.V.max(axis=0)
        self.diagonal = float(np.linalg.norm(hi - lo))

    def cast(
        self, camera: OrthographicCamera, pixels: NDArray[np.float64], *, exact: bool = True
    ) -> SurfaceHits:
        """The first surface hit of the ray through each pixel position.

        Parameters
        ----------
        camera : OrthographicCamera
        pixels : (n, 2) float64
            Image positions ``(x, y)``; pixel centres are at integer + 0.5.
        exact : bool
            Recompute each hit in float64 (ray-plane intersection in the triangle Embree found);
            otherwise Embree's float32 barycentrics (round-off then shows in the shading).

        Returns
        -------
        SurfaceHits
        """
        p = np.asarray(pixels, dtype=np.float64).reshape(-1, 2)
        n = p.shape[0]
        start = float(np.max(camera.depth(self.V))) + 0.01 * self.diagonal + 1e-12
        origins, directions = camera.rays(p, start)
        query = self._scene.run(origins, directions)
        triangle = np.where(query["geomID"] >= 0, query["primID"], -1).astype(np.int64)
        hit = triangle >= 0
        bary = np.zeros((n, 3))
        points = np.full((n, 3), np.nan)
        if hit.any():
            corners = self.V[self.F[triangle[hit]]]
            if exact:
                nrm = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
                den = nrm @ directions[0]
                den = np.where(np.abs(den) > 0, den, 1e-300)
                t = np.einsum("kd,kd->k", corners[:, 0] - origins[hit], nrm) / den
                bary[hit] = _barycentric(corners, origins[hit] + t[:, None] * directions[hit])
            else:
                u = query["u"][hit].astype(np.float64)
                v = query["v"][hit].astype(np.float64)
                bary[hit] = np.column_stack([1.0 - u - v, u, v])
            points[hit] = np.einsum("kj,kjd->kd", bary[hit], corners)
        return SurfaceHits(hit, triangle, bary, points)

    def facing(self, camera: OrthographicCamera, hits: SurfaceHits) -> NDArray[np.float64]:
        """|cos| of the angle between the interpolated normal and the view axis, (n,), 0 off-mesh."""
        out = np.zeros(hits.hit.shape[0])
        h = hits.hit
        if h.any():
            nrm = np.einsum("kj,kjd->kd", hits.barycentric[h], self.normals[self.F[hits.triangle[h]]])
            nrm /= np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-300)
            out[h] = np.abs(nrm @ camera.rotation[2])
        return out

    def render(self, camera: OrthographicCamera) -> Render:
        """Render the mesh: grey Lambert, light at the camera, black background.

        Returns
        -------
        Render
        """
        s = camera.size
        ys, xs = np.mgrid[0:s, 0:s]
        pix = np.column_stack([xs.ravel() + 0.5, ys.ravel() + 0.5])
        hits = self.cast(camera, pix)
        shade = self.facing(camera, hits)
        image = np.where(hits.hit, np.round(30.0 + 210.0 * shade), 0.0).astype(np.uint8)
        depth = np.full(s * s, -np.inf)
        if hits.hit.any():
            depth[hits.hit] = camera.depth(hits.points[hits.hit])
        return Render(
            camera,
            image.reshape(s, s),
            hits.triangle.reshape(s, s),
            hits.barycentric.reshape(s, s, 3),
            depth.reshape(s, s),
        )


def _barycentric(corners: NDArray[np.float64], p: NDArray[np.float64]) -> NDArray[np.float64]:
    """Barycentric coordinates (k, 3) of points p (k, 3) in triangles corners (k, 3, 3)."""
    a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
    v0, v1, v2 = b - a, c - a, p - a
    d00 = np.einsum("kd,kd->k", v0, v0)
    d01 = np.einsum("kd,kd->k", v0, v1)
    d11 = np.einsum("kd,kd->k", v1, v1)
    d20 = np.einsum("kd,kd->k", v2, v0)
    d21 = np.einsum("kd,kd->k", v2, v1)
    den = d00 * d11 - d01 * d01
    den = np.where(np.abs(den) > 0, den, 1.0)
    w1 = (d11 * d20 - d01 * d21) / den
    w2 = (d00 * d21 - d01 * d20) / den
    w = np.column_stack([1.0 - w1 - w2, w1, w2])
    return np.clip(w, 0.0, 1.0) / np.clip(w, 0.0, 1.0).sum(axis=1, keepdims=True).clip(1e-300)
