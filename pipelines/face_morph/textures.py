"""Appearance read from the key files: texture coordinates and images, vertex colours; PNG bytes."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

#: longest side of the texture atlas resampled onto the consistent mesh (texels)
MAX_TEXTURE_SIZE = 2048


def png_bytes(image: NDArray[np.uint8]) -> bytes:
    """PNG bytes of an (h, w, 3) uint8 image."""
    import io

    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(image), "RGB").save(buf, "PNG")
    return buf.getvalue()


def _load_trimesh(mesh_path: str | Path, file_type: str | None) -> Any:
    import trimesh

    path = Path(mesh_path)
    ftype = (file_type or path.suffix.lstrip(".")).lower()
    with open(path, "rb") as fh:
        return trimesh.load(fh, file_type=ftype, process=False, maintain_order=True, force="mesh")


def read_texture(
    mesh_path: str | Path, image_path: str | Path, n_vertices: int, *, file_type: str | None = None
) -> tuple[NDArray[np.float64], NDArray[np.uint8]]:
    """Per-vertex texture coordinates of a mesh file and its texture image.

    Parameters
    ----------
    mesh_path : path
        The mesh (OBJ with one ``vt`` per vertex, or any trimesh-readable
        file with per-vertex UVs).
    image_path : path
        The texture image (any format PIL reads).
    n_vertices : int
        Vertex count of the mesh as read by :func:`conformorph.pipelines.mesh_io.read_mesh`.
    file_type : str, optional
        Mesh file type when the path has no telling extension.

    Returns
    -------
    uv : (n, 2) float64
        Texture coordinates, origin at the image's bottom-left corner (OBJ
        convention).
    image : (h, w, 3) uint8
        RGB texels, row 0 at the top.

    Raises
    ------
    ValueError
        The mesh has no per-vertex UVs (or UVs that split vertices at seams).
    OSError
        The image cannot be read.
    """
    from PIL import Image

    m = _load_trimesh(mesh_path, file_type)
    uv = getattr(getattr(m, "visual", None), "uv", None)
    if uv is None or len(uv) != n_vertices:
        raise ValueError(
            f"{mesh_path}: --texture needs one texture coordinate per vertex (vt), "
            f"found {0 if uv is None else len(uv)} for {n_vertices} vertices"
        )
    uv = np.asarray(uv, dtype=np.float64)
    if not np.all(np.isfinite(uv)):
        raise ValueError(f"{mesh_path}: non-finite texture coordinates")
    with Image.open(image_path) as im:
        img = np.asarray(im.convert("RGB"), dtype=np.uint8)
    return uv, img


def read_vertex_colors(
    mesh_path: str | Path, n_vertices: int, *, file_type: str | None = None
) -> NDArray[np.float64] | None:
    """Per-vertex RGB colours stored in a mesh file (PLY colour properties, OBJ ``v x y z r g b``).

    Parameters
    ----------
    mesh_path : path
    n_vertices : int
        Vertex count of the mesh as read by :func:`conformorph.pipelines.mesh_io.read_mesh`.
    file_type : str, optional
        Mesh file type when the path has no telling extension.

    Returns
    -------
    (n, 3) float64 in [0, 1], or None
        None when the file has no vertex colours (or not one per vertex).
    """
    path = Path(mesh_path)
    ftype = (file_type or path.suffix.lstrip(".")).lower()
    if ftype in ("obj", "ply"):
        # cheap look first: most meshes carry no colours, and parsing twice costs time
        with open(path, "rb") as fh:
            head = fh.read(1 << 16)
        if ftype == "ply":
            header = head.split(b"end_header")[0]
            if b" red" not in header and b" r\n" not in header:
                return None
        else:
            vline = next((ln for ln in head.splitlines() if ln.startswith(b"v ")), b"")
            if len(vline.split()) < 7:
                return None
    m = _load_trimesh(mesh_path, file_type)
    vis = getattr(m, "visual", None)
    if vis is None or getattr(vis, "kind", None) != "vertex":
        return None
    c = np.asarray(vis.vertex_colors)
    if c.ndim != 2 or c.shape[0] != n_vertices or c.shape[1] < 3:
        return None
    return np.asarray(c[:, :3], dtype=np.float64) / 255.0
