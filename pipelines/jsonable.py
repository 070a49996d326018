"""Diagnostics (dataclasses, numpy arrays and scalars, non-finite floats) as JSON values."""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np


def jsonable(value: Any, *, summarize_arrays_over: int | None = None) -> Any:
    """Convert diagnostics to JSON-ready values.

    Parameters
    ----------
    value : any
        Dicts, lists, tuples, dataclass instances, numpy arrays and scalars,
        and plain JSON values, nested.
    summarize_arrays_over : int, optional
        Arrays with more elements than this become ``{"shape", "dtype"}``
        instead of nested lists (default: every array is listed in full).

    Returns
    -------
    any
        Built of dicts (string keys), lists, str, int, float, bool and None;
        non-finite floats become None, and any other object its ``str``.
    """
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {
            f.name: jsonable(getattr(value, f.name), summarize_arrays_over=summarize_arrays_over)
            for f in dataclasses.fields(value)
        }
    if isinstance(value, dict):
        return {
            str(k): jsonable(v, summarize_arrays_over=summarize_arrays_over)
            for k, v in value.items()
        }
    if isinstance(value, list | tuple):
        return [jsonable(v, summarize_arrays_over=summarize_arrays_over) for v in value]
    if isinstance(value, np.ndarray):
        if summarize_arrays_over is not None and value.size > summarize_arrays_over:
            return {"shape": list(value.shape), "dtype": str(value.dtype)}
        return jsonable(value.tolist())
    if isinstance(value, np.generic):
        return jsonable(value.item())
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, str | int | float | bool) or value is None:
        return value
    return str(value)
