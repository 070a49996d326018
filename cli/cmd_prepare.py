"""``conformorph prepare``: a raw scan made into the clean disk the pipelines take."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from conformorph.cli._output import add_vertex_budget_option, print_json


def register(subparsers: Any) -> None:
    """Add the ``prepare`` command."""
    p = subparsers.add_parser(
        "prepare",
        help="prepare a raw scan: clean-up, largest component, manifold repair, faired hole "
        "filling, ear removal; the face cut out of a closed head",
        description=(
            "Prepare a raw mesh for map/reconstruct/morph: drop unreferenced vertices, "
            "degenerate and duplicate faces; repair non-manifold edges and vertices; keep the "
            "largest component; fill holes (inner boundary loops up to half the outer loop's "
            "length) with faired patches; remove boundary ears; when the mesh is still not a disk "
            "(a closed head, a scan with a neck and a back, several large boundary loops), cut "
            "the face out as a disk (around the landmarks with --landmarks, else around the most "
            "protruding point). Writes OUT.obj and "
            "OUT.obj.prepare.json (the report and 'vertex_map': the input row of every output "
            "vertex, -1 for added ones). Above --vertex-budget vertices the cleaned mesh is "
            "decimated (quadric edge collapse): an output vertex is then the input vertex no "
            "collapse removed, moved to the quadric-optimal point, and 'merged_into' gives, for "
            "every input vertex, the input row of the vertex it was merged into. Exit 1 when "
            "the result is still not a disk."
        ),
    )
    p.add_argument("mesh", metavar="MESH", help="mesh file (OBJ, PLY, OFF, STL, GLB, glTF)")
    p.add_argument("-o", "--output", required=True, metavar="OUT.obj", help="prepared mesh")
    p.add_argument(
        "--max-hole-fraction",
        type=float,
        default=0.5,
        metavar="F",
        help="fill a hole when its loop is at most F times the outer loop's length (default 0.5)",
    )
    add_vertex_budget_option(p)
    p.add_argument(
        "--landmarks",
        metavar="L.json",
        help="landmark file of this one mesh (vertex ids or points, as 'morph' reads them): "
        "where the face is cut out of a closed head; the report's 'landmark_rows' gives each "
        "landmark's output row (-1: removed; a point keeps its nearest vertex's row)",
    )
    p.add_argument("--json", action="store_true", help="print the report as one JSON object")
    p.set_defaults(handler=run_prepare)


def _landmark_vertices(path: str, V: Any, F: Any) -> Any:
    """Vertex (k,) of each landmark of a one-mesh landmark file: its id, or a point's nearest
    corner; the file checked as ``morph`` checks it (bad entries raise its errors)."""
    import numpy as np

    from conformorph.pipelines.landmark_document import read_landmark_file
    from conformorph.pipelines.landmarks_io import resolve_landmarks

    lms = resolve_landmarks(list(read_landmark_file(path, 1)[0]), V, F)
    corner = F[lms.triangle, np.argmax(lms.barycentric, axis=1)]
    return np.where(lms.vertex >= 0, lms.vertex, corner)


def _face_cut_note(report: dict[str, Any]) -> str:
    """``", face cut out (…)"`` when the preparation cut the face out, else ``""``."""
    cut = report.get("face_cut")
    if not cut or "problem" in cut:
        return ""
    return f", face cut out ({cut['kept_faces']} faces kept, {cut['removed_faces']} removed)"


def run_prepare(args: argparse.Namespace) -> int:
    """Handler of ``conformorph prepare``."""
    import sys

    from conformorph.pipelines.mesh_io import read_mesh, write_obj
    from conformorph.pipelines.preparation import PrepareOptions, prepare_mesh_arrays

    options = PrepareOptions(
        max_hole_fraction=args.max_hole_fraction, vertex_budget=args.vertex_budget
    )
    V, F = read_mesh(args.mesh)
    ids = _landmark_vertices(args.landmarks, V, F) if args.landmarks else None
    prepared = prepare_mesh_arrays(V, F, options, landmark_ids=ids)
    out = Path(args.output)
    write_obj(out, prepared.V, prepared.F)
    report: dict[str, Any] = {"mesh": str(args.mesh), "output": str(out), **prepared.report}
    if ids is not None:
        from conformorph.pipelines.preparation import input_landmark_ids

        report["landmark_rows"] = input_landmark_ids(prepared, ids, V).tolist()
    sidecar = out.with_name(out.name + ".prepare.json")
    tmp = sidecar.with_name(sidecar.name + ".tmp")
    maps: dict[str, Any] = {"vertex_map": prepared.vertex_map.tolist()}
    if prepared.merged_into is not None:
        maps["merged_into"] = prepared.merged_into.tolist()
    tmp.write_text(json.dumps({**report, **maps}))
    tmp.replace(sidecar)
    report["vertex_map_file"] = str(sidecar)
    if args.json:
        print_json(report)
    else:
        r = prepared.report
        print(
            f"wrote {out} ({r['output']['vertices']} vertices, {r['output']['faces']} faces; "
            f"input {r['input']['vertices']}, {r['input']['faces']}): "
            f"{r['removed_vertices']} input vertices removed, "
            f"{len(r.get('filled_holes', []))} holes filled, "
            f"{len(r.get('dropped_components', []))} components dropped"
            + (
                f", decimated to the vertex budget {r['decimation']['vertex_budget']}"
                if r.get("decimation")
                else ""
            )
            + f"{_face_cut_note(r)}; report {sidecar}"
        )
    if not prepared.report["disk"]:
        print(
            f"conformorph prepare: the prepared mesh is still not a disk: "
            f"{prepared.report['problem']}",
            file=sys.stderr,
        )
        return 1
    return 0
