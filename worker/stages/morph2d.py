"""Stage body of the 2D morph (``POST /v1/morphs2d``): one stage running
:func:`pipelines.morph2d_pipeline.run_morph2d` into a scratch folder whose files
become the job's artifacts."""

from __future__ import annotations

import json

from pipelines.jsonable import jsonable
from worker import names
from worker.job_runner import StageBody, StageContext


def morph2d_stage(ctx: StageContext) -> None:
    """The whole 2D strain-field morph (``run_morph2d``) into the job's artifacts.

    Input errors name their input (``source``, ``target``, ``anchors[i][side]``, ``paths[k]``,
    ``texture``: set by ``run_morph2d``); a morph that does not reach the
    target fails the job with the reason (``morph_not_converged``).
    """
    from pipelines.morph2d_pipeline import run_morph2d
    from pipelines.shape_io import DEFAULT_MAX_POINTS

    p = ctx.params
    src = ctx.storage.local_path(p["source"]["storage_key"])
    dst = ctx.storage.local_path(p["target"]["storage_key"])
    tex = ctx.storage.local_path(p["texture"]["storage_key"]) if p.get("texture") else None
    with ctx.scratch_dir() as d:
        anchors = d / "anchors.json"
        anchors.write_text(json.dumps({"anchors": p["anchors"], "paths": p.get("paths") or None}))
        out = d / "out"

        def progress(current: int, total: int, stage: str) -> None:
            ctx.progress(current / max(1, total))

        metrics = run_morph2d(
            src,
            dst,
            anchors,
            out,
            frames=int(p.get("frames", 60)),
            interp=p.get("interp", "modified"),
            pace=p.get("pace", "strain"),
            per_frame=bool(p.get("per_frame", False)),
            progress=progress,
            texture_path=tex,
            max_points=int(p.get("max_points", DEFAULT_MAX_POINTS)),
            solver_options=p.get("solver_options"),  # internal callers only; the API sets none
        )
        metrics["source"], metrics["target"] = p["source"]["id"], p["target"]["id"]
        (out / "metrics.json").write_text(json.dumps(jsonable(metrics), indent=2) + "\n")
        for f in sorted(out.rglob("*")):
            if f.is_file():
                ctx.put_file(f.relative_to(out).as_posix(), f)


STAGE_BODIES: dict[str, StageBody] = {names.STAGE_MORPH2D: morph2d_stage}
