"""Whether a mesh file carries texture coordinates, read from its bytes in one pass.

The upload report records it (``report.texture_coordinates``) so that a morph
asking for a texture on a mesh without any is refused at submission (422), not
after its stages ran. A file with texture coordinates may still lack one per
vertex (seams split in the file); the morph's texture step says so then.
"""

from __future__ import annotations

import re

#: an OBJ texture-coordinate line ``vt u v``; ``[ \t]*``, not ``\s*``: one attempt per
#: line start, so the search is linear in the bytes
_OBJ_VT = re.compile(rb"(?m)^[ \t]*vt[ \t]")
#: a PLY vertex property that trimesh reads as a texture coordinate
_PLY_UV = re.compile(
    rb"(?m)^property[ \t]+\w+[ \t]+(?:s|t|u|v|texture_u|texture_v|texture_s|texture_t)[ \t]*\r?$"
)
#: most header bytes a PLY file is searched for (its header is far shorter)
PLY_HEADER_BYTES = 1 << 16


def has_texture_coordinates(data: bytes, file_type: str) -> bool:
    """True when the mesh file holds texture coordinates.

    Parameters
    ----------
    data : bytes
        The file.
    file_type : str
        ``obj``, ``ply``, ``glb``, ``gltf``, ``off`` or ``stl``.

    Returns
    -------
    bool
        OBJ: a ``vt`` line; PLY: a vertex property ``s``/``t``/``u``/``v`` (or
        ``texture_*``) in the header; glTF/GLB: a ``TEXCOORD_0`` attribute; OFF
        and STL hold none.
    """
    kind = file_type.lower().lstrip(".")
    if kind == "obj":
        return _OBJ_VT.search(data) is not None
    if kind == "ply":
        header = data[:PLY_HEADER_BYTES].split(b"end_header", 1)[0]
        return _PLY_UV.search(header) is not None
    if kind in ("glb", "gltf"):
        return b'"TEXCOORD_0"' in data
    return False
