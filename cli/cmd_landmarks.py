"""``conformorph landmarks MESH [MESH ...] -o L.json``: find the 68 Multi-PIE landmarks of face
meshes automatically (MediaPipe FaceMesh on a ray-cast render), for ``morph --landmarks``.

Needs the optional packages mediapipe==0.10.14 and embreex (see the README). A
named detection failure (no face, a view from behind, a low score, a face too
small in the render, rays lost through holes) is one line on stderr and exit 2;
an open mouth is a warning in the file (inner-lip points get low confidence).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from conformorph.cli._output import print_json


def detection_options_from_args(args: argparse.Namespace) -> Any:
    """The ``DetectionOptions`` the flags ask for (the one place flags map onto options)."""
    from conformorph.pipelines.landmark_detection.detect import DetectionOptions

    return DetectionOptions(min_score=args.min_score)


def run_landmarks(args: argparse.Namespace) -> int:
    try:
        from conformorph.pipelines.landmark_detection.detect import detect_landmarks, shared_models
        from conformorph.pipelines.landmark_detection.landmark_file import (
            landmark_file_document,
            write_preview,
        )

        models = shared_models()
    except ImportError as exc:
        print(f"conformorph landmarks: error: {exc}", file=sys.stderr)
        return 2
    from conformorph.pipelines.landmark_detection.multipie68 import TABLE_PATH
    from conformorph.pipelines.mesh_io import read_mesh

    options = detection_options_from_args(args)
    results = []
    for mesh in args.meshes:
        V, F = read_mesh(mesh)
        try:
            results.append(detect_landmarks(V, F, options, models=models))
        except ValueError as exc:
            raise type(exc)(f"{mesh}: {exc}") from exc
        except ImportError as exc:  # embreex missing: an install problem, said in one line
            print(f"conformorph landmarks: error: {exc}", file=sys.stderr)
            return 2
    detector = {"name": "mediapipe-facemesh", "version": models.version,
                "table": TABLE_PATH.name, "model_load_seconds": round(models.load_seconds, 3),
                "seconds": [round(r.seconds, 3) for r in results]}
    doc = landmark_file_document(results, [str(m) for m in args.meshes], detector)
    out = Path(args.output)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(out.name + ".tmp")
    tmp.write_text(json.dumps(doc) + "\n", encoding="utf-8")
    tmp.replace(out)
    if args.preview:
        Path(args.preview).mkdir(parents=True, exist_ok=True)
        for mesh, r in zip(args.meshes, results, strict=True):
            write_preview(r, Path(args.preview) / f"{Path(mesh).stem}_landmarks.png")
    if args.json:
        print_json({
            "output": str(out), "model_load_seconds": detector["model_load_seconds"],
            "meshes": [
                {"mesh": str(m), "score": r.score, "seconds": r.seconds,
                 "min_confidence": float(r.confidence.min()), "warnings": list(r.warnings)}
                for m, r in zip(args.meshes, results, strict=True)
            ],
        })
    elif args.quiet:  # no per-mesh lines; warnings still said, on stderr
        for m, r in zip(args.meshes, results, strict=True):
            for w in r.warnings:
                print(f"warning: landmarks: {m}: {w}", file=sys.stderr)
        print(f"wrote {out}")
    else:
        for m, r in zip(args.meshes, results, strict=True):
            extra = f"; {len(r.warnings)} warning(s): " + " | ".join(r.warnings) if r.warnings else ""
            print(f"{m}: 68 landmarks, score {r.score:.2f}, {r.seconds:.2f} s{extra}")
        print(f"wrote {out}")
    return 0


def register(sub: Any) -> None:
    """Add the ``landmarks`` command."""
    p = sub.add_parser(
        "landmarks", help="detect the 68 Multi-PIE landmarks of face meshes (for morph --landmarks)"
    )
    p.add_argument("meshes", nargs="+", metavar="MESH", help="face meshes (OBJ, PLY, OFF, STL, GLB)")
    p.add_argument("-o", "--output", required=True, help="landmark file to write (JSON)")
    p.add_argument("--preview", metavar="DIR", help="write a PNG per mesh with the landmarks drawn")
    p.add_argument("--min-score", type=float, default=0.5,
                   help="face-detector score below which detection fails (default 0.5)")
    p.add_argument("--json", action="store_true", help="print one JSON object with the results")
    p.add_argument("-q", "--quiet", action="store_true",
                   help="no line per mesh (warnings still go to stderr), only 'wrote FILE'")
    p.set_defaults(handler=run_landmarks)
