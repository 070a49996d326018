"""A million-vertex scan uploads within the default limits: streamed to disk, read and
validated by the worker's validation, its report naming the working resolution."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from conformorph.pipelines.preparation import DEFAULT_VERTEX_BUDGET
from conformorph.service.core.config import Settings
from conformorph.service.schemas import VERTEX_BUDGET_DEFAULT
from tests.service.conftest import Api


def grid_disk_obj(k: int) -> bytes:
    """A k x k grid of vertices (a gently curved square, a disk) as OBJ bytes, 6 decimals."""
    x, y = np.meshgrid(np.linspace(-1, 1, k), np.linspace(-1, 1, k))
    V = np.column_stack([x.ravel(), y.ravel(), 0.2 * np.exp(-(x**2 + y**2)).ravel()])
    i = np.arange(k - 1)[:, None] * k + np.arange(k - 1)[None, :]
    q = i.ravel()
    F = np.vstack([np.c_[q, q + 1, q + k + 1], np.c_[q, q + k + 1, q + k]]) + 1
    v_lines = "\n".join(map("v {:.6f} {:.6f} {:.6f}".format, *V.T))
    f_lines = "\n".join(map("f {} {} {}".format, *F.T))
    return (v_lines + "\n" + f_lines + "\n").encode()


def test_default_limits_take_a_million_vertex_scan() -> None:
    s = Settings()
    assert s.max_vertices >= 1_100_000 and s.max_faces >= 2_200_000
    assert s.max_upload_bytes >= 116_000_000  # 1.09M vertices written with 17 digits
    assert VERTEX_BUDGET_DEFAULT == DEFAULT_VERTEX_BUDGET  # the API's default is the CLI's


@pytest.mark.slow
def test_million_vertex_upload_is_validated(tmp_path: Path) -> None:
    data = grid_disk_obj(1000)  # 1,000,000 vertices, 1,996,002 faces, 72 MB
    assert len(data) < Settings().max_upload_bytes
    api = Api(tmp_path)
    try:
        r = api.client.post("/v1/meshes", files={"file": ("scan.obj", data)})
        assert r.status_code == 201, r.text
        body = r.json()
        assert body["vertices"] == 1_000_000 and body["faces"] == 2 * 999 * 999
        assert body["report"]["working_resolution"]["vertex_budget"] == DEFAULT_VERTEX_BUDGET
        assert body["size_bytes"] == len(data)
        # over the vertex limit: refused with a reason, not a 500
        small = Api(tmp_path / "small", max_vertices=500_000)
        try:
            r2 = small.client.post("/v1/meshes", files={"file": ("scan.obj", data)})
            assert r2.status_code == 422 and "500000" in r2.text.replace(",", "")
        finally:
            small.client.close()
            small.store.dispose()
    finally:
        api.client.close()
        api.store.dispose()
