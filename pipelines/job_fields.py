"""The jobs' shared defaults and numeric ranges: one definition for every entry point.

The API (``service/schemas.py`` and the routes), the CLI (``conformorph morph``,
``submit``, ``batch`` manifests), the client (``conformorph_client``, which carries
a copy of this module written by ``tools/sync_client_models.py``) and the
pipelines' options all read their defaults and ranges from here, so that a value
one entry point accepts is one every other accepts and the numerics can honour.

Pure Python: only the standard library (the API must not load numpy, and the
client copy must install alone).

Ranges (a careful numerical analyst's choice where the papers say nothing):

* **Key times** (``times``, ``--times``): finite, strictly increasing, within
  ``±TIME_LIMIT``; their span ``tN − t0`` at least ``MIN_TIME_SPAN`` and at least
  ``TIME_MAGNITUDE_RTOL`` × their largest magnitude (else the spline's divided
  differences ``Δy/Δt`` overflow or lose their digits: ``[0, 1e-320]`` and
  ``[0, 1e308]`` crashed the frames stage); consecutive times at least
  ``TIME_SPACING_RTOL`` × the span apart (the animation's float32 key-frame times,
  counted from the first frame, stay distinct).
* **Frame times** (``frame_times``, ``--frame-times``): finite, strictly
  increasing, consecutive ones at least ``TIME_SPACING_RTOL`` × the key span
  apart, and within ``EXTRAPOLATION_SPANS`` key spans outside ``[t0, tN]``: the
  homotopy's cubic spline extrapolates (the paper's Table 4), and its error grows
  as the cube of the distance (measured on two ICT faces: 3 spans out morphs, 10
  spans out the frame solve is singular, 1000 spans out the metric is not finite).
* **Coordinates** (mesh vertices, shape points, landmark points): finite, within
  ``±COORDINATE_LIMIT`` (areas and squared lengths stay far from overflow), and a
  mesh's or shape's extent at least ``EXTENT_RTOL`` × its largest coordinate (else
  its differences have no digits left). Anchors must lie in their shape, so within
  its range.
* **Confidences** (a landmark document's ``confidence``): one number in [0, 1]
  per landmark, one list per mesh.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Final

# --------------------------------------------------------------------------- defaults

#: values of ``prepare`` / ``--prepare``
PREPARE_CHOICES = ("auto", "none")
#: the morph's default preparation (``POST /v1/morphs``, ``conformorph morph``,
#: ``submit``, batch manifests, the viewer): clean up, repair and decimate to the
#: vertex budget first; a clean disk under the budget is left as read
MORPH_PREPARE_DEFAULT: Final = "auto"
#: the single-mesh jobs' default preparation (conformal map, reconstruction, as
#: ``conformorph map``): their outputs are per input vertex, so the mesh is kept as read
MAP_PREPARE_DEFAULT: Final = "none"
#: whether a face morph also builds the MT-only registration baseline and measures its
#: key frames (``baselines`` / ``--baselines``): off, as ``conformorph morph`` has always
#: had it; it costs about 0.17 s on two 7k-vertex faces (measured, issue 32)
MORPH_BASELINES_DEFAULT: Final = False
#: default working resolution (vertices) of ``prepare: auto`` (the figures behind it are
#: in :mod:`conformorph.pipelines.preparation.options`)
VERTEX_BUDGET_DEFAULT = 50_000
#: smallest vertex budget accepted (0, or None on the CLI, never decimates)
MIN_VERTEX_BUDGET = 1_000
#: values of ``landmark_fit`` / ``--landmark-fit``
LANDMARK_FIT_CHOICES = ("auto", "exact", "tolerant")
#: ``auto``: ``tolerant`` for detected landmarks, ``exact`` for given ones
LANDMARK_FIT_DEFAULT: Final = "auto"

# --------------------------------------------------------------------------- ranges

#: largest magnitude of a key or frame time
TIME_LIMIT = 1e9
#: smallest span ``tN − t0`` of the key times
MIN_TIME_SPAN = 1e-6
#: smallest gap between consecutive key or frame times, relative to the key span (float32
#: glTF times over up to 3 spans resolve 2e-7 of a span)
TIME_SPACING_RTOL = 1e-6
#: smallest key span relative to the times' magnitude (float64 differences keep 7 digits)
TIME_MAGNITUDE_RTOL = 1e-9
#: how far (in key spans) frame times may lie outside ``[t0, tN]``
EXTRAPOLATION_SPANS = 1.0
#: largest magnitude of a coordinate (mesh vertices, shape points, landmark points)
COORDINATE_LIMIT = 1e12
#: smallest extent of a mesh or shape relative to its largest coordinate
EXTENT_RTOL = 1e-9


class FieldRangeError(ValueError):
    """A value outside the range the numerics honour (API: 422; CLI: exit code 2).

    Parameters
    ----------
    message : str
        What is wrong, in the API's words (field names, not flags).
    field : str
        Where: the field and index, e.g. ``frame_times[3]``.
    """

    code = "out_of_range"

    def __init__(self, message: str, field: str) -> None:
        super().__init__(message)
        self.field = field


def _number(x: object) -> bool:
    return isinstance(x, int | float) and not isinstance(x, bool)


def _finite_in_limit(values: Sequence[float], field: str, limit: float, what: str) -> None:
    for k, t in enumerate(values):
        if not _number(t) or not math.isfinite(t) or abs(t) > limit:
            raise FieldRangeError(
                f"{field}[{k}] is {t!r}: {what} must be finite numbers within ±{limit:g}",
                f"{field}[{k}]",
            )


def _increasing(values: Sequence[float], field: str, gap: float) -> None:
    for k in range(1, len(values)):
        if values[k] - values[k - 1] < gap or values[k] <= values[k - 1]:
            raise FieldRangeError(
                f"{field} must be strictly increasing with consecutive values at least "
                f"{gap:.3g} apart; {field}[{k - 1}] = {values[k - 1]!r}, "
                f"{field}[{k}] = {values[k]!r}",
                f"{field}[{k}]",
            )


def check_key_times(times: Sequence[float], n_keys: int, field: str = "times") -> None:
    """Check key times against the range the homotopy honours.

    Parameters
    ----------
    times : sequence of float, length n_keys
        The key times t0 < … < tN.
    n_keys : int
        Number of key meshes.
    field : str, optional
        The field's name in messages.

    Raises
    ------
    FieldRangeError
        Wrong count, a value not finite or beyond ``±TIME_LIMIT``, a span below
        ``MIN_TIME_SPAN`` or below ``TIME_MAGNITUDE_RTOL`` × the largest magnitude,
        or consecutive times closer than ``TIME_SPACING_RTOL`` × the span.
    """
    if len(times) != n_keys:
        raise FieldRangeError(
            f"{field} needs {n_keys} values (one per mesh), got {len(times)}", field
        )
    _finite_in_limit(times, field, TIME_LIMIT, "key times")
    if n_keys < 2:
        return
    span = times[-1] - times[0]
    floor = max(MIN_TIME_SPAN, TIME_MAGNITUDE_RTOL * max(abs(times[0]), abs(times[-1])))
    if not span >= floor:
        raise FieldRangeError(
            f"{field} span {times[0]!r} … {times[-1]!r} is below {floor:.3g}: key times "
            f"must span at least {MIN_TIME_SPAN:g} and {TIME_MAGNITUDE_RTOL:g} of their "
            "magnitude",
            field,
        )
    _increasing(times, field, TIME_SPACING_RTOL * span)


def check_frame_times(
    frame_times: Sequence[float], times: Sequence[float], field: str = "frame_times"
) -> None:
    """Check explicit frame times against the key times (already checked).

    Parameters
    ----------
    frame_times : sequence of float, length ≥ 1
    times : sequence of float
        The key times (``check_key_times`` passed), or the default ``0 … N``.
    field : str, optional
        The field's name in messages.

    Raises
    ------
    FieldRangeError
        Empty, not finite, not strictly increasing by at least
        ``TIME_SPACING_RTOL`` × the key span, or more than ``EXTRAPOLATION_SPANS``
        key spans outside ``[t0, tN]``.
    """
    if len(frame_times) < 1:
        raise FieldRangeError(f"{field} needs at least one time", field)
    _finite_in_limit(frame_times, field, TIME_LIMIT, "frame times")
    t0, tn = float(times[0]), float(times[-1])
    span = tn - t0
    lo, hi = t0 - EXTRAPOLATION_SPANS * span, tn + EXTRAPOLATION_SPANS * span
    for k, t in enumerate(frame_times):
        if not lo <= t <= hi:
            raise FieldRangeError(
                f"{field}[{k}] = {t!r} lies outside [{lo:g}, {hi:g}]: frame times may "
                f"extrapolate at most {EXTRAPOLATION_SPANS:g} key span(s) beyond the key "
                f"times {t0:g} … {tn:g}",
                f"{field}[{k}]",
            )
    _increasing(frame_times, field, TIME_SPACING_RTOL * span)


def check_morph_times(
    times: Sequence[float] | None, frame_times: Sequence[float] | None, n_keys: int
) -> None:
    """:func:`check_key_times` (when given) then :func:`check_frame_times` (when given).

    Parameters
    ----------
    times : sequence of float or None
        Key times; None means ``0, 1, …, n_keys − 1``.
    frame_times : sequence of float or None
        Explicit frame times; None means evenly spaced frames (always in range).
    n_keys : int
        Number of key meshes.

    Raises
    ------
    FieldRangeError
    """
    keys: Sequence[float] = [float(k) for k in range(n_keys)] if times is None else times
    if times is not None:
        check_key_times(times, n_keys)
    if frame_times is not None:
        check_frame_times(frame_times, keys)


def check_point(point: Sequence[float], field: str) -> None:
    """One point's coordinates: finite numbers within ``±COORDINATE_LIMIT``.

    Raises
    ------
    FieldRangeError
    """
    for c in point:
        if not _number(c) or not math.isfinite(c) or abs(c) > COORDINATE_LIMIT:
            raise FieldRangeError(
                f"{field} holds {c!r}: coordinates must be finite numbers within "
                f"±{COORDINATE_LIMIT:g}",
                field,
            )


def check_extent(largest: float, extent: float, field: str) -> None:
    """A point set's coordinates against its extent.

    Parameters
    ----------
    largest : float
        The largest coordinate magnitude.
    extent : float
        The bounding box's diagonal.
    field : str
        What the message calls the point set.

    Raises
    ------
    FieldRangeError
        ``largest`` beyond ``COORDINATE_LIMIT`` (or not finite), or ``extent`` not
        above ``EXTENT_RTOL`` × ``largest`` (no digits left in the differences).
    """
    if not math.isfinite(largest) or largest > COORDINATE_LIMIT:
        raise FieldRangeError(
            f"{field}: a coordinate of magnitude {largest:.3g}; coordinates must be finite "
            f"and within ±{COORDINATE_LIMIT:g}",
            field,
        )
    if not extent > EXTENT_RTOL * largest:
        raise FieldRangeError(
            f"{field}: extent {extent:.3g} is below {EXTENT_RTOL:g} of its coordinates' "
            f"magnitude {largest:.3g}; translate it nearer the origin",
            field,
        )


def check_confidence(confidence: object, counts: Sequence[int], field: str = "confidence") -> None:
    """A landmark document's ``confidence``: one list of numbers in [0, 1] per mesh.

    Parameters
    ----------
    confidence : object
        The document's ``confidence`` value (decoded JSON).
    counts : sequence of int
        The number of landmarks of each mesh.
    field : str, optional

    Raises
    ------
    FieldRangeError
        Not one list per mesh, a list whose length is not its mesh's landmark
        count, or an entry that is not a number in [0, 1].
    """
    if not isinstance(confidence, list) or len(confidence) != len(counts):
        raise FieldRangeError(f"{field} must hold one list per mesh ({len(counts)} lists)", field)
    for i, (row, n) in enumerate(zip(confidence, counts, strict=True)):
        if not isinstance(row, list) or len(row) != n:
            got = len(row) if isinstance(row, list) else type(row).__name__
            raise FieldRangeError(
                f"{field}[{i}] must hold one value per landmark of mesh {i} ({n}), got {got}",
                f"{field}[{i}]",
            )
        for j, c in enumerate(row):
            if not _number(c) or not 0.0 <= c <= 1.0:
                raise FieldRangeError(
                    f"{field}[{i}][{j}] is {c!r}: confidences are numbers in [0, 1]",
                    f"{field}[{i}][{j}]",
                )
