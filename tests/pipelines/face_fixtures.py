"""Small synthetic "faces" for the face-morph tests (generated, no shared data needed)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from conformorph.geometry.consistent_mesh import landmark_disk_mesh, refine_disk_mesh

#: landmark positions on the parameter plane: eyes, nose, mouth corners, chin, brows
LANDMARK_UV = np.array(
    [
        [-0.3, 0.3],
        [0.3, 0.3],
        [0.0, 0.05],
        [-0.25, -0.35],
        [0.25, -0.35],
        [0.0, -0.6],
        [-0.35, 0.55],
        [0.35, 0.55],
    ]
)


def face_mesh(
    smile: float = 0.0, levels: int = 3, seed: int = 0
) -> tuple[np.ndarray, np.ndarray, list[int]]:
    """A disk-topology height field with a nose and a mouth; ``smile`` lifts the mouth corners.

    Returns V (n, 3), F (m, 3) and the landmark vertex ids.
    """
    rng = np.random.default_rng(seed)
    jitter = rng.uniform(-0.02, 0.02, (12, 2))
    base = np.array(
        [[0.6 * np.cos(a), 0.6 * np.sin(a)] for a in np.linspace(0, 2 * np.pi, 12, endpoint=False)]
    )
    uv, F = refine_disk_mesh(
        *landmark_disk_mesh(np.vstack([LANDMARK_UV, base + jitter]), n_boundary=20), levels
    )
    x, y = uv[:, 0], uv[:, 1]
    nose = 0.35 * np.exp(-((x / 0.12) ** 2 + ((y - 0.05) / 0.25) ** 2))
    mouth_y = -0.35 + smile * 0.15 * (x / 0.25) ** 2
    mouth = -0.05 * np.exp(-(((y - mouth_y) / 0.05) ** 2 + (x / 0.3) ** 2))
    dome = 0.4 * (1 - 0.5 * (x**2 + y**2))
    V = np.c_[x * (1 + 0.1 * smile * np.exp(-(((y + 0.35) / 0.2) ** 2))), y, dome + nose + mouth]
    lm = [int(np.argmin(np.linalg.norm(uv - p, axis=1))) for p in LANDMARK_UV]
    return V, F.astype(np.int64), lm


def write_obj(path: Path, V: np.ndarray, F: np.ndarray) -> Path:
    lines = [f"v {a:.17g} {b:.17g} {c:.17g}" for a, b, c in V]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in F]
    path.write_text("\n".join(lines) + "\n")
    return path
