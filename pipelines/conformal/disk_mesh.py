"""A disk mesh as read and as repaired: what ``conformorph map``/``reconstruct`` and
the API's conformal-map and reconstruction jobs run the numerics on (step 1 of
:mod:`conformorph.pipelines.conformal`).

Every output keeps the input file's vertices, in its order, and its faces,
whatever the repairs: ``fill_holes`` adds hole centres that the numerics
use and the outputs leave out; ``remove_ears`` removes boundary ears from
the numerics, after which a map's ``uv`` puts them back on the unit circle
(:func:`geometry.extend_uv_to_ears`, ``kept`` False for them) and a
reconstruction gives them their input positions (they are boundary
vertices, whose positions are given).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from conformorph import geometry
from conformorph.pipelines.mesh_io import read_mesh
from conformorph.pipelines.preparation.options import DEFAULT_VERTEX_BUDGET


@dataclass(frozen=True)
class DiskMesh:
    """An input mesh and the repaired disk the numerics run on.

    Attributes
    ----------
    V_in : (n, 3) float64
    F_in : (m, 3) int64
        The mesh as read, in the file's order.
    V : (n2, 3) float64
    F : (m2, 3) int64
        After ``--fill-holes`` (hole centres appended) and ``--remove-ears``.
    V_filled : (n + h, 3) float64
    F_filled : (m + f, 3) int64
        After ``--fill-holes`` only: the input, then ``h`` hole centres and
        ``f`` fan faces (the input itself without it).
    kept : (n2,) int64
        Row ``j`` of ``V`` is row ``kept[j]`` of ``V_filled`` (increasing).
    done : dict
        What was repaired, for the JSON report (``preparation``: the report of
        ``--prepare auto``).
    vertex_map : (n,) int64 or None
        With ``--prepare auto`` when it changed the mesh: ``V_in`` is then the
        *prepared* mesh, and ``vertex_map[i]`` the file's row of its vertex
        ``i`` (-1 for a vertex the preparation added).
    """

    V_in: np.ndarray
    F_in: np.ndarray
    V: np.ndarray
    F: np.ndarray
    V_filled: np.ndarray
    F_filled: np.ndarray
    kept: np.ndarray
    done: dict[str, Any]
    vertex_map: np.ndarray | None = None

    def input_rows(self, values: np.ndarray, removed: np.ndarray) -> np.ndarray:
        """Per-vertex ``values`` (rows of ``V``) as rows of the input, in its order.

        ``removed`` (one row per row of ``V_filled``) supplies the rows of
        vertices that were removed as ears; hole centres are dropped.
        """
        full = np.array(removed, dtype=np.float64, copy=True)
        full[self.kept] = values
        return full[: self.V_in.shape[0]]

    def vertex(self, index: int) -> int:
        """Row of ``V`` of input vertex ``index`` (ValueError for a removed ear)."""
        k = int(np.searchsorted(self.kept, int(index)))
        if k >= self.kept.size or int(self.kept[k]) != int(index):
            raise ValueError(f"vertex {int(index)} is a boundary ear removed by remove_ears")
        return k

    def input_uv(self, uv: np.ndarray) -> np.ndarray:
        """A disk map (rows of ``V``, (n2, 2)) on the input's rows (n, 2): removed ears put
        back on the unit circle (:func:`geometry.extend_uv_to_ears`), an unfolded disk map
        of the whole input."""
        return self.input_rows(uv, geometry.extend_uv_to_ears(uv, self.F_filled, self.kept))

    def kept_mask(self) -> np.ndarray:
        """(n,) bool: input vertices the numerics ran on (False: a removed ear)."""
        mask = np.zeros(self.V_filled.shape[0], dtype=bool)
        mask[self.kept] = True
        return mask[: self.V_in.shape[0]]


@dataclass(frozen=True)
class RepairOptions:
    """The repairs asked for (``--fill-holes``/``--remove-ears``, the jobs' ``fill_holes``/
    ``remove_ears``).

    Attributes
    ----------
    fill_holes : bool
        Fill inner boundary loops with a fan around a new centre vertex
        (:func:`geometry.fill_holes`). Default False.
    remove_ears : bool
        Remove boundary ear vertices (in one triangle only,
        :func:`geometry.remove_boundary_ears`). Default False.
    prepare : str
        ``"auto"``: run the preparation step first
        (:func:`conformorph.pipelines.preparation.prepare_mesh_arrays`) and treat its output as
        the input (outputs are on the prepared mesh's vertices; its vertex map
        relates them to the file's); ``"none"`` (default): the file as read.
    vertex_budget : int or None
        With ``prepare="auto"``, the working resolution
        (:attr:`conformorph.pipelines.preparation.PrepareOptions.vertex_budget`; None never
        decimates). Default ``DEFAULT_VERTEX_BUDGET`` (50,000).
    """

    fill_holes: bool = False
    remove_ears: bool = False
    prepare: str = "none"
    vertex_budget: int | None = DEFAULT_VERTEX_BUDGET

    def __post_init__(self) -> None:
        from conformorph.pipelines.preparation import PREPARE_MODES

        if self.prepare not in PREPARE_MODES:
            raise ValueError(
                f"prepare must be one of {', '.join(PREPARE_MODES)}, got {self.prepare!r}"
            )


def load_disk_mesh(path: str | Path, repairs: RepairOptions) -> DiskMesh:
    """Read the mesh file (vertex order kept) and :func:`prepared_disk_mesh` it."""
    V_in, F_in = read_mesh(path)
    return prepared_disk_mesh(V_in, F_in, repairs)


def prepared_disk_mesh(V_in: Any, F_in: Any, repairs: RepairOptions) -> DiskMesh:
    """The preparation step when ``repairs.prepare == "auto"``, then :func:`repair_disk_mesh`.

    Parameters
    ----------
    V_in : (n, 3) array_like of float
    F_in : (m, 3) array_like of int
        The mesh as read.
    repairs : RepairOptions

    Returns
    -------
    DiskMesh
        With ``prepare="auto"``, on the prepared mesh (``V_in``/``F_in`` are the
        prepared arrays, ``done["preparation"]`` the report, ``vertex_map``
        set when the preparation changed the mesh).

    Raises
    ------
    UnpreparableMeshError
        When the prepared mesh is still not a disk (the validation's message).
    """
    if repairs.prepare != "auto":
        return repair_disk_mesh(
            V_in, F_in, fill_holes=repairs.fill_holes, remove_ears=repairs.remove_ears
        )
    from dataclasses import replace

    from conformorph.pipelines.preparation import (
        PrepareOptions,
        UnpreparableMeshError,
        prepare_mesh_arrays,
    )

    prepared = prepare_mesh_arrays(V_in, F_in, PrepareOptions(vertex_budget=repairs.vertex_budget))
    if not prepared.report["disk"]:
        raise UnpreparableMeshError(
            f"still not a disk after preparation: {prepared.report['problem']}"
        )
    mesh = repair_disk_mesh(
        prepared.V, prepared.F, fill_holes=repairs.fill_holes, remove_ears=repairs.remove_ears
    )
    return replace(
        mesh,
        done={**mesh.done, "preparation": prepared.report},
        vertex_map=prepared.vertex_map if prepared.changed else None,
    )


def require_interior_vertex(F: np.ndarray, command: str) -> None:
    """Raise a clear ValueError when every vertex is on the boundary (nothing to reconstruct).

    Parameters
    ----------
    F : (m, 3) int64
        Triangles of the (repaired) mesh.
    command : str
        What needs the interior vertices, for the message.
    """
    n = int(F.max()) + 1
    if np.unique(geometry.mesh_edges(F).boundary).size == n:
        raise ValueError(
            f"{command} needs interior vertices: all {n} vertices of this mesh lie on its "
            "boundary, whose positions are given, so there is nothing to reconstruct"
        )


def repair_disk_mesh(V_in: Any, F_in: Any, *, fill_holes: bool, remove_ears: bool) -> DiskMesh:
    """Check the mesh and apply the requested repairs.

    The element checks (shapes, finite coordinates, face indices, zero areas,
    unreferenced vertices) run first; when a repair is asked for, so do
    manifoldness, a single component and (without ``fill_holes``) disk
    topology, so that a bad file gets its own error rather than a failure
    inside a repair. The full validation runs on the repaired mesh in
    :func:`conformorph.geometry.disk_conformal_map`.
    """
    if fill_holes or remove_ears:
        geometry.validate_mesh(V_in, F_in, require_disk=not fill_holes, allow_ears=True)
    else:
        geometry.validate_mesh_elements(V_in, F_in)
    V, F = V_in, F_in
    done: dict[str, Any] = {}
    if fill_holes:
        V, F = geometry.fill_holes(V, F)
        done["filled_holes"] = int(V.shape[0] - V_in.shape[0])
    V_filled, F_filled = V, F
    kept = np.arange(V.shape[0], dtype=np.int64)
    if remove_ears:
        V, F, kept = geometry.remove_boundary_ears(V, F)
        removed = np.setdiff1d(np.arange(V_filled.shape[0]), kept)
        done["removed_ear_vertices"] = int(removed.size)
        done["removed_ear_vertex_ids"] = removed.tolist()
    return DiskMesh(V_in, F_in, V, F, V_filled, F_filled, kept, done)
