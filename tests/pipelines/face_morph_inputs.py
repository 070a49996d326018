"""Inputs and checks shared by the face-morph pipeline tests (synthetic faces, GLB validation)."""

import json
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from conformorph.pipelines.face_morph import (
    ExportOptions,
    FaceMorphOptions,
    FrameOptions,
    KeyOptions,
    RegistrationOptions,
    run_face_morph,
)
from tests.meshes import SHARED_FACES

from .face_fixtures import face_mesh, write_obj

ROOT = Path(__file__).resolve().parents[2]
SHARED = SHARED_FACES

_GROUPS = {
    "keys": KeyOptions,
    "registration": RegistrationOptions,
    "homotopy": FrameOptions,
    "export": ExportOptions,
}


def morph_options(**flat):
    """FaceMorphOptions from flat keywords, each routed to the options class with that field."""
    groups = {g: {} for g in _GROUPS}
    top = {}
    for k, v in flat.items():
        g = next((g for g, cls in _GROUPS.items() if k in cls.__dataclass_fields__), None)
        if g is None:
            top[k] = tuple(v) if k in ("times", "frame_times") and v is not None else v
        else:
            groups[g][k] = v
    return FaceMorphOptions(**top, **{g: _GROUPS[g](**kw) for g, kw in groups.items()})


def morph(paths, landmarks, out, *, textures=None, truths=(), progress=None, **flat):
    """run_face_morph with the options given as flat keywords (see :func:`morph_options`)."""
    return run_face_morph(
        paths,
        landmarks,
        out,
        morph_options(**flat),
        textures=textures,
        truths=truths,
        progress=progress,
    )


def face_inputs(tmp_path, smiles=(0.0, 1.0), reorder_last=False, subdivide_first=False):
    paths, lms = [], []
    for i, s in enumerate(smiles):
        V, F, lm = face_mesh(s, levels=4 if (subdivide_first and i == 0) else 3)
        if reorder_last and i == len(smiles) - 1:
            perm = np.random.default_rng(5).permutation(V.shape[0])
            inv = np.argsort(perm)
            V, F, lm = V[perm], inv[F], [int(inv[j]) for j in lm]
        paths.append(write_obj(tmp_path / f"m{i}.obj", V, F))
        lms.append(lm)
    L = tmp_path / "l.json"
    L.write_text(json.dumps({"landmarks": lms}))
    return paths, L


def validate_glb(files):
    node = shutil.which("node")
    if node is None or not (ROOT / "node_modules" / "gltf-validator").is_dir():
        pytest.skip("node / npm gltf-validator not installed")
    proc = subprocess.run(
        [node, str(ROOT / "tools" / "gltf_validate.mjs"), *map(str, files)],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=120,
    )
    reports = [json.loads(x) for x in proc.stdout.splitlines() if x.startswith("{")]
    assert len(reports) == len(files), proc.stderr
    for r in reports:
        assert (r["errors"], r["warnings"]) == (0, 0), r


def write_textured_obj(path, V, F, uv):
    lines = [f"v {a:.17g} {b:.17g} {c:.17g}" for a, b, c in V]
    lines += [f"vt {a:.17g} {b:.17g}" for a, b in uv]
    lines += [f"f {a + 1}/{a + 1} {b + 1}/{b + 1} {c + 1}/{c + 1}" for a, b, c in F]
    path.write_text("\n".join(lines) + "\n")
    return path


def gradient_image(h, w, blue):
    """R = u, G = v (OBJ convention, v up), B = blue: linear, so bilinear sampling is exact."""
    r, c = np.mgrid[0:h, 0:w]
    u, v = (c + 0.5) / w, 1.0 - (r + 0.5) / h
    return np.stack([u, v, np.full_like(u, blue)], axis=2)


def textured_inputs(tmp_path, reorder_last=False):
    """Two textured faces: mesh 1's UVs and image are mirrored left-right (a different
    layout of the same picture) and its blue channel is 1 where mesh 0's is 0."""
    from PIL import Image

    paths, lms, imgs = [], [], []
    V0 = face_mesh(0.0)[0]
    for i, s in enumerate((0.0, 1.0)):
        V, F, lm = face_mesh(s)
        uv = 0.5 + 0.45 * V0[:, :2]  # vertex j shows the same texel on both (before mirroring)
        img = gradient_image(32, 40, blue=float(i))
        if i == 1:
            uv[:, 0] = 1.0 - uv[:, 0]
            img = img[:, ::-1]
            if reorder_last:
                perm = np.random.default_rng(5).permutation(V.shape[0])
                inv = np.argsort(perm)
                V, F, lm, uv = V[perm], inv[F], [int(inv[j]) for j in lm], uv[perm]
        paths.append(write_textured_obj(tmp_path / f"t{i}.obj", V, F, uv))
        lms.append(lm)
        imgs.append(tmp_path / f"tex{i}.png")
        Image.fromarray(np.rint(img * 255).astype(np.uint8)).save(imgs[-1])
    L = tmp_path / "l.json"
    L.write_text(json.dumps({"landmarks": lms}))
    return paths, L, imgs


def glb_texture(path):
    import io

    from PIL import Image
    from pygltflib import GLTF2

    g = GLTF2().load(str(path))
    bv = g.bufferViews[g.images[0].bufferView]
    data = g.binary_blob()[bv.byteOffset : bv.byteOffset + bv.byteLength]
    return g, np.asarray(Image.open(io.BytesIO(data)).convert("RGB"), dtype=np.float64) / 255


def write_coloured_obj(path, V, F, C):
    lines = [
        f"v {a:.17g} {b:.17g} {c:.17g} {r:.6f} {g:.6f} {b2:.6f}"
        for (a, b, c), (r, g, b2) in zip(V, C, strict=True)
    ]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in F]
    path.write_text("\n".join(lines) + "\n")
    return path


def folded_face():
    """face_mesh(1.0) with one interior vertex pushed through its neighbours: its
    disk map folds before the fold repair (2 triangles with fold_policy="report")."""
    V, F, lm = face_mesh(1.0)
    i = int(np.argmin(np.hypot(V[:, 0] - 0.3, V[:, 1])))
    V[i, :2] += [0.35, 0.0]
    return V, F, lm
