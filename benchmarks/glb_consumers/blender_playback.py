"""Import a morph GLB into Blender (the ``bpy`` wheel) and write what it shows at times.

Run with the Python of a venv holding ``bpy`` (never the project's .venv)::

    BPY_VENV/bin/python blender_playback.py FILE.glb OUT.npz T [T ...]

The file is imported by ``bpy.ops.import_scene.gltf`` with its default options into an
empty factory scene. Written to OUT.npz:

* ``meta`` (a JSON string): Blender's version, the import's outcome (``error`` when it
  refused the file, with its message), the top object's rest transform (the mesh object
  or its top-level parent, glTF node 0: location, rotation quaternion, scale of its world
  matrix at t = 0, as Blender keeps no rest apart from the action), the mesh object's
  own transform when it sits under a parent (a quantized file's dequantization), the
  animated data paths of the object and of its shape keys, the shape-key count, the
  scene's frames per second, and the material's shading (whether a Color Attribute node
  or an image texture feeds it);
* ``positions`` (T, n, 3): the evaluated mesh's world vertex positions at each time
  (``scene.frame_set`` at t × fps with the sub-frame, then the depsgraph), turned back
  from Blender's Z-up to glTF's Y-up (glTF x, y, z = Blender x, z, -y);
* ``corner_normals`` (T, m, 3) and ``corner_vertex`` (m,): the normals Blender shades
  each face corner with (``Mesh.corner_normals`` of the evaluated mesh, world, Y-up),
  and the vertex of each corner;
* ``colors`` (T, n, 4): the first colour attribute of the evaluated mesh per vertex
  (linear floats; corner-domain colours averaged per vertex), when there is one.
"""

from __future__ import annotations

import json
import math
import sys
from typing import Any

import bpy
import numpy as np

# glTF (x, y, z) from Blender (x, y, z): the inverse of the importer's Y-up conversion
TO_GLTF = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])


def fcurve_paths(id_data) -> list[str]:
    """Data paths animated on an ID block (Blender 4.4+ slotted actions and older)."""
    anim = getattr(id_data, "animation_data", None)
    if anim is None or anim.action is None:
        return []
    action = anim.action
    curves = []
    if hasattr(action, "layers") and len(action.layers):
        from bpy_extras.anim_utils import action_get_channelbag_for_slot

        bag = action_get_channelbag_for_slot(action, anim.action_slot)
        curves = list(bag.fcurves) if bag is not None else []
    elif hasattr(action, "fcurves"):
        curves = list(action.fcurves)
    return sorted({f"{c.data_path}[{c.array_index}]" for c in curves})


def shading(obj) -> dict:
    """What feeds the first material's surface: colour attributes, image textures."""
    mats = [s.material for s in obj.material_slots if s.material is not None]
    if not mats or mats[0].node_tree is None:
        return {"materials": [m.name for m in mats]}
    nodes = mats[0].node_tree.nodes
    return {
        "materials": [m.name for m in mats],
        "color_attribute_nodes": sum(n.bl_idname == "ShaderNodeVertexColor" for n in nodes),
        "image_texture_nodes": sum(n.bl_idname == "ShaderNodeTexImage" for n in nodes),
    }


def evaluated(obj, depsgraph) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]:
    """World positions (n, 3), corner normals (m, 3), corner vertices (m,), colours."""
    ev = obj.evaluated_get(depsgraph)
    mesh = ev.to_mesh()
    n, m = len(mesh.vertices), len(mesh.loops)
    co = np.zeros(3 * n)
    mesh.vertices.foreach_get("co", co)
    W = np.array(ev.matrix_world)
    P = co.reshape(n, 3) @ W[:3, :3].T + W[:3, 3]
    cn = np.zeros(3 * m)
    mesh.corner_normals.foreach_get("vector", cn)
    normal_matrix = np.linalg.inv(W[:3, :3]).T
    N = cn.reshape(m, 3) @ normal_matrix.T
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    lv = np.zeros(m, dtype=np.int64)
    mesh.loops.foreach_get("vertex_index", lv)
    colors: np.ndarray | None = None
    if len(mesh.color_attributes):
        attr = mesh.color_attributes[0]
        flat = np.zeros(4 * len(attr.data))
        attr.data.foreach_get("color", flat)
        raw = flat.reshape(-1, 4)
        if attr.domain == "CORNER":
            colors = np.zeros((n, 4))
            np.add.at(colors, lv, raw)
            colors /= np.maximum(np.bincount(lv, minlength=n), 1)[:, None]
        else:
            colors = raw
    ev.to_mesh_clear()
    return P @ TO_GLTF.T, N @ TO_GLTF.T, lv, colors


def main(argv: list[str]) -> int:
    if len(argv) < 3:
        print("usage: blender_playback.py FILE.glb OUT.npz T [T ...]", file=sys.stderr)
        return 2
    path, out, times = argv[0], argv[1], [float(t) for t in argv[2:]]
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    meta: dict = {
        "blender": bpy.app.version_string,
        "fps": scene.render.fps / scene.render.fps_base,
    }
    try:
        bpy.ops.import_scene.gltf(filepath=path)
    except Exception as exc:  # the importer's refusal is the finding
        meta["error"] = str(exc).strip().splitlines()[-1] if str(exc).strip() else repr(exc)
        np.savez(out, meta=json.dumps(meta))
        return 0
    obj = next(o for o in scene.objects if o.type == "MESH")
    top = obj
    while top.parent is not None:
        top = top.parent
    # Blender keeps no rest apart from the action (the import's first evaluation writes
    # the animated values into the object): the top object's own transform at t = 0
    scene.frame_set(0)
    loc, rot, scale = top.matrix_world.decompose()
    meta["rest"] = {
        "name": top.name,
        "location": list(loc),
        "rotation_quaternion": list(rot),
        "scale": list(scale),
    }
    if top is not obj:  # a quantized file's dequantization child
        lloc, lrot, lscale = obj.matrix_local.decompose()
        meta["mesh_local"] = {"location": list(lloc), "scale": list(lscale)}
    keys = obj.data.shape_keys
    meta["animated_object"] = fcurve_paths(top) + fcurve_paths(obj) * (top is not obj)
    meta["animated_shape_keys"] = len(fcurve_paths(keys)) if keys is not None else 0
    meta["shape_keys"] = len(keys.key_blocks) if keys is not None else 0
    meta["frame_range"] = [scene.frame_start, scene.frame_end]
    meta["shading"] = shading(obj)
    meta["custom_normals"] = bool(obj.data.has_custom_normals)
    frames = []
    fps = meta["fps"]
    for t in times:
        f = t * fps
        whole = math.floor(f)
        scene.frame_set(whole, subframe=f - whole)
        frames.append(evaluated(obj, bpy.context.evaluated_depsgraph_get()))
    arrays: dict[str, Any] = {
        "positions": np.stack([f[0] for f in frames]),
        "corner_normals": np.stack([f[1] for f in frames]),
        "corner_vertex": frames[0][2],
    }
    colours = [f[3] for f in frames if f[3] is not None]
    if colours:
        arrays["colors"] = np.stack(colours)
    np.savez(out, meta=json.dumps(meta), **arrays)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
