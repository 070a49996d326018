"""Units of the face keys: each key's length unit declared or inferred, the keys brought to
one scale before the morph (key 0's unit), the GLB written in metres.

glTF lengths are metres, and the keys of one morph may come in different units (a scan in
millimetres, a model in centimetres). Each key's unit is, in order of preference:

1. **declared** (``conformorph morph --units mm|cm|m``, the job field and batch key
   ``units``): taken as given;
2. **inferred from the landmarks** when the key has the 68 ibug points: the distance
   between the outer eye corners (ibug 36 and 45, 0-based) is 8.5–10 cm on adult faces,
   so the unit is the one of mm, cm and m that puts the measured distance nearest (in
   ratio) to 9.25 cm;
3. **inferred from the face's size** otherwise: the unit that puts the surface's diameter
   (largest distance between two vertices) nearest to 20 cm, the diameter of an adult
   face mask (the ICT face: 20.5 cm).

Inferred keys are then made to agree: a key more than :data:`SIZE_MISMATCH` from the first
key inferred from landmarks (else key 0) takes the unit nearest that key's size.

The choice is among decimal units, never a continuous factor: a face keeps its real size
(a child's face stays small) and only the unit is read. Each key is then scaled by
``metres_per_unit[i] / metres_per_unit[0]`` (the morph runs in key 0's unit, as before
for keys of one unit, which are left untouched) and the export multiplies by
``metres_per_unit[0]``. Keys whose diameters still differ by more than
:data:`SIZE_MISMATCH` after that are refused with a message naming both keys and their
sizes: a face and a full head, or a wrong declaration.

Only the scale-carrying fields of a stage-1 key change (``V``, its normalisation's
translation and scale, the landmark snap distances, the reported diameter): everything
else of stage 1 is computed on the diameter-normalised surface and is unit-free.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

Arrays = dict[str, Any]

#: the units a key may be declared in, with their length in metres
METRES_PER_UNIT: dict[str, float] = {"mm": 1e-3, "cm": 1e-2, "m": 1.0}
#: what the entry points accept (``--units``, the job field, the batch key)
UNIT_CHOICES = ("auto", *METRES_PER_UNIT)
#: the one default of ``--units``, the job field ``units`` and the batch key
DEFAULT_UNITS = "auto"
#: ibug-68 indices (0-based) of the outer eye corners
OUTER_EYE_CORNERS = (36, 45)
#: adult outer-eye-corner distance, metres (8.5–10 cm); the inference aims at the middle
EYE_CORNER_DISTANCE = (0.085, 0.10)
#: diameter of an adult face mask, metres (the ICT face: 0.205 m)
FACE_DIAMETER = 0.20
#: keys whose diameters differ by more than this ratio after the units are refused
SIZE_MISMATCH = 2.0


class UnitsMismatchError(ValueError):
    """Keys whose sizes disagree by more than :data:`SIZE_MISMATCH` after their units."""

    code = "units_mismatch"


@dataclass(frozen=True)
class KeyUnits:
    """The unit of one key and how it was found.

    Attributes
    ----------
    units : {"mm", "cm", "m"}
    metres_per_unit : float
    source : {"declared", "landmarks", "size", "size, matched to mesh i"}
    measured : float
        The measure the inference read, in the key's own unit: the outer-eye-corner
        distance (``source == "landmarks"``) or the diameter (otherwise).
    """

    units: str
    metres_per_unit: float
    source: str
    measured: float


def check_units(units: str) -> str:
    """``units`` if it is one of :data:`UNIT_CHOICES`, else a ``ValueError`` saying which are."""
    if units not in UNIT_CHOICES:
        raise ValueError(f"units must be one of {', '.join(UNIT_CHOICES)}, got {units!r}")
    return units


def nearest_unit(measured: float, reference: float) -> str:
    """The unit of :data:`METRES_PER_UNIT` putting ``measured`` nearest to ``reference`` metres.

    Nearest in ratio (``|log(measured · m_u / reference)|``), so that 0.5× and 2× are
    equally far.

    Parameters
    ----------
    measured : float
        A length in an unknown unit, > 0.
    reference : float
        What it is expected to be, in metres, > 0.

    Returns
    -------
    str
    """
    if not (np.isfinite(measured) and measured > 0):
        raise ValueError(f"a key's size must be finite and positive, got {measured}")
    return min(
        METRES_PER_UNIT, key=lambda u: abs(np.log(measured * METRES_PER_UNIT[u] / reference))
    )


def _landmark_points(p: Arrays) -> np.ndarray:
    """(m, 3) landmark points of a stage-1 key in its input coordinates."""
    return np.einsum("mj,mjk->mk", p["lm_bary"], p["V"][p["F"][p["lm_tri"]]])


def key_units(p: Arrays, declared: str = DEFAULT_UNITS) -> KeyUnits:
    """The unit of one stage-1 key: declared, else from its landmarks, else from its size.

    Parameters
    ----------
    p : stage-1 dict
        ``V``, ``F``, ``lm_tri``, ``lm_bary`` and ``meta["diameter"]``.
    declared : {"auto", "mm", "cm", "m"}
        ``"auto"`` infers (see the module's notes).

    Returns
    -------
    KeyUnits
    """
    check_units(declared)
    diameter = float(p["meta"]["diameter"])
    if declared != "auto":
        return KeyUnits(declared, METRES_PER_UNIT[declared], "declared", diameter)
    if np.asarray(p["lm_tri"]).size == 68:
        a, b = OUTER_EYE_CORNERS
        P = _landmark_points(p)
        d = float(np.linalg.norm(P[b] - P[a]))
        if d > 0:
            u = nearest_unit(d, float(np.mean(EYE_CORNER_DISTANCE)))
            return KeyUnits(u, METRES_PER_UNIT[u], "landmarks", d)
    u = nearest_unit(diameter, FACE_DIAMETER)
    return KeyUnits(u, METRES_PER_UNIT[u], "size", diameter)


def rescale_key(p: Arrays, factor: float) -> Arrays:
    """A stage-1 key with its lengths multiplied by ``factor`` (a new dict; ``p`` unchanged).

    Scales ``V``, ``norm_translation``, ``norm_scale``, ``lm_snap`` and the reported
    diameter and snap distance; the normalised surface, its disk map, curvature and
    conformal factor are unit-free and kept (``V = norm_scale · Vn + norm_translation``).
    """
    if factor == 1.0:
        return p
    out = dict(p)
    for name in ("V", "norm_translation", "norm_scale", "lm_snap"):
        out[name] = np.asarray(p[name], dtype=np.float64) * factor
    meta = dict(p["meta"])
    meta["diameter"] = float(meta["diameter"]) * factor
    if "landmark_snap_distance_max" in meta:
        meta["landmark_snap_distance_max"] = float(meta["landmark_snap_distance_max"]) * factor
    out["meta"] = meta
    return out


def keys_to_one_scale(
    prepared: Sequence[Arrays], declared: str = DEFAULT_UNITS
) -> tuple[list[Arrays], dict[str, Any]]:
    """Every key in key 0's unit, and the units report for ``metrics.json``.

    Parameters
    ----------
    prepared : sequence of stage-1 dicts
        The keys in their own units.
    declared : {"auto", "mm", "cm", "m"}
        The unit of every key, or ``"auto"`` to infer each key's own.

    Returns
    -------
    keys : list of stage-1 dicts
        Key i scaled by ``metres_per_unit[i] / metres_per_unit[0]``; each key's
        ``meta["units"]`` is its entry of the report.
    report : dict
        ``{"declared", "working_unit", "metres_per_working_unit", "keys": [{"units",
        "metres_per_unit", "source", "measured", "factor_to_working_unit",
        "diameter_m"}, …]}``.

    Raises
    ------
    UnitsMismatchError
        Two keys' diameters in metres differ by more than :data:`SIZE_MISMATCH`.
    """
    found = _consistent_units(prepared, [key_units(p, declared) for p in prepared])
    m0 = found[0].metres_per_unit
    keys: list[Arrays] = []
    rows: list[dict[str, Any]] = []
    for p, ku in zip(prepared, found, strict=True):
        factor = ku.metres_per_unit / m0
        row = {
            "units": ku.units,
            "metres_per_unit": ku.metres_per_unit,
            "source": ku.source,
            "measured": ku.measured,
            "factor_to_working_unit": factor,
            "diameter_m": float(p["meta"]["diameter"]) * ku.metres_per_unit,
        }
        q = rescale_key(p, factor)
        q = {**q, "meta": {**q["meta"], "units": row}}
        keys.append(q)
        rows.append(row)
    sizes = [float(r["diameter_m"]) for r in rows]
    big, small = int(np.argmax(sizes)), int(np.argmin(sizes))
    if sizes[big] > SIZE_MISMATCH * sizes[small]:
        raise UnitsMismatchError(
            f"the keys' sizes disagree: mesh {big} is {_how(rows[big])} and mesh {small} "
            f"{_how(rows[small])}, {sizes[big] / sizes[small]:.3g}× apart (more than "
            f"{SIZE_MISMATCH:g}×); declare each file's units (--units, the job field "
            "'units') or give faces of one extent (a face, not a whole head)"
        )
    report = {
        "declared": declared,
        "working_unit": found[0].units,
        "metres_per_working_unit": m0,
        "keys": rows,
    }
    return keys, report


def units_summary(inputs: Sequence[dict[str, Any]], declared: str) -> dict[str, Any]:
    """The ``units`` report of :func:`keys_to_one_scale` rebuilt from the keys' ``meta``
    (a job's metrics stage reads the stored keys; a key without ``meta["units"]`` counts
    as metres, factor 1)."""
    rows = [dict(m.get("units") or {}) for m in inputs]
    m0 = float(rows[0].get("metres_per_unit", 1.0)) if rows else 1.0
    return {
        "declared": declared,
        "working_unit": rows[0].get("units", "m") if rows else "m",
        "metres_per_working_unit": m0,
        "keys": rows,
    }


def _consistent_units(prepared: Sequence[Arrays], found: list[KeyUnits]) -> list[KeyUnits]:
    """Inferred units made to agree: a key whose own inference leaves it more than
    :data:`SIZE_MISMATCH` from the anchor (the first key inferred from landmarks, else key 0)
    takes the unit that brings its diameter nearest the anchor's (``source`` ``"size"``,
    ``matched_to`` the anchor). A face of about 2 units across is as far from 20 cm in
    centimetres as in metres: inferred alone, two such keys could land on either side."""
    inferred = [i for i, ku in enumerate(found) if ku.source != "declared"]
    if len(inferred) < 2:
        return found
    anchor = next((i for i in inferred if found[i].source == "landmarks"), inferred[0])
    diam = [float(p["meta"]["diameter"]) for p in prepared]
    target = diam[anchor] * found[anchor].metres_per_unit
    out = list(found)
    for i in inferred:
        if i == anchor:
            continue
        size = diam[i] * found[i].metres_per_unit
        if max(size, target) > SIZE_MISMATCH * min(size, target):
            u = nearest_unit(diam[i], target)
            out[i] = KeyUnits(u, METRES_PER_UNIT[u], f"size, matched to mesh {anchor}", diam[i])
    return out


def _how(row: dict[str, Any]) -> str:
    """'20.5 cm across (units cm, from landmarks)' for a key's report row."""
    return (
        f"{row['diameter_m'] * 100:.3g} cm across (units {row['units']}, "
        f"{'declared' if row['source'] == 'declared' else 'inferred from its ' + row['source']})"
    )
