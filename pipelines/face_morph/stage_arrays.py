"""A stage's dict of arrays on disk (``.npz``), so that a worker can run the stages apart."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from conformorph.pipelines.face_morph.options import Arrays
from conformorph.pipelines.jsonable import jsonable


def save_stage(path: str | Path, arrays: Arrays) -> None:
    """Save a stage's dict of arrays as ``.npz`` (``meta`` dicts as JSON), atomically."""
    out: dict[str, NDArray[Any]] = {}
    for k, v in arrays.items():
        if k == "meta":
            out["meta_json"] = np.array(json.dumps(jsonable(v)))
        else:
            out[k] = np.asarray(v)
    p = Path(path)
    tmp = p.with_name(p.name + ".tmp")
    with open(tmp, "wb") as fh:
        np.savez(fh, **out)  # type: ignore[arg-type]
    tmp.replace(p)


def load_stage(path: str | Path) -> Arrays:
    """Load a stage saved by :func:`save_stage`."""
    with np.load(path, allow_pickle=False) as z:
        d: Arrays = {k: z[k] for k in z.files}
    if "meta_json" in d:
        d["meta"] = json.loads(str(d.pop("meta_json")))
    return d
