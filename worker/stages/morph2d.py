"""Stage body of the 2D morph (``POST /v1/morphs2d``): one stage running
:func:`conformorph.pipelines.morph2d.run_morph2d` into a scratch folder whose files
become the job's artifacts."""

from __future__ import annotations

import json
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from conformorph.pipelines.jsonable import jsonable
from conformorph.worker import names
from conformorph.worker.job_runner import StageBody, StageContext

if TYPE_CHECKING:
    from conformorph.pipelines.morph2d import Morph2DOptions


def morph2d_options_from_params(params: Mapping[str, Any]) -> Morph2DOptions:
    """The job's parameters as pipeline options (the one place they map).

    ``solver_options`` (keyword fields of
    :class:`conformorph.geometry.strain_morph.StrainMorphOptions`) is for internal callers
    only; the API sets none.
    """
    from conformorph.geometry.strain_morph import StrainMorphOptions
    from conformorph.pipelines.animation_loop import DEFAULT_LOOP
    from conformorph.pipelines.glb_placement import DEFAULT_SVG_UNITS
    from conformorph.pipelines.morph2d import DEFAULT_INTERP, Morph2DOptions
    from conformorph.pipelines.shape_io import DEFAULT_MAX_POINTS

    return Morph2DOptions(
        frames=int(params.get("frames", 60)),
        interp=params.get("interp", DEFAULT_INTERP),
        pace=params.get("pace", "strain"),
        per_frame=bool(params.get("per_frame", False)),
        units=str(params.get("units") or DEFAULT_SVG_UNITS),
        size=None if params.get("size") is None else float(params["size"]),
        loop=params.get("loop", DEFAULT_LOOP),
        max_points=int(params.get("max_points", DEFAULT_MAX_POINTS)),
        point_budget=None if params.get("point_budget") is None else int(params["point_budget"]),
        solver=StrainMorphOptions(**(params.get("solver_options") or {})),
    )


def morph2d_stage(ctx: StageContext) -> None:
    """The whole 2D strain-field morph (``run_morph2d``) into the job's artifacts.

    Input errors name their input (``source``, ``target``, ``anchors[i][side]``, ``paths[k]``,
    ``texture``: set by ``run_morph2d``); a morph that does not reach the
    target fails the job with the reason (``morph_not_converged``).
    """
    from conformorph.pipelines.morph2d import run_morph2d

    p = ctx.params
    options = morph2d_options_from_params(p)
    src = ctx.storage.local_path(p["source"]["storage_key"])
    dst = ctx.storage.local_path(p["target"]["storage_key"])
    tex = ctx.storage.local_path(p["texture"]["storage_key"]) if p.get("texture") else None
    with ctx.scratch_dir() as d:
        anchors = None  # found automatically (and written to the artifact anchors.json)
        if p.get("anchors") is not None:
            anchors = d / "anchors.json"
            anchors.write_text(
                json.dumps({"anchors": p["anchors"], "paths": p.get("paths") or None})
            )
        out = d / "out"

        def progress(current: int, total: int, stage: str) -> None:
            ctx.progress(current / max(1, total))

        metrics = run_morph2d(src, dst, anchors, out, options, texture_path=tex, progress=progress)
        metrics["source"], metrics["target"] = p["source"]["id"], p["target"]["id"]
        (out / "metrics.json").write_text(json.dumps(jsonable(metrics), indent=2) + "\n")
        for f in sorted(out.rglob("*")):
            if f.is_file():
                ctx.put_file(f.relative_to(out).as_posix(), f)


STAGE_BODIES: dict[str, StageBody] = {names.STAGE_MORPH2D: morph2d_stage}
