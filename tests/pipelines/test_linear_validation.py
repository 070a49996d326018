"""Every upload check is linear in the bytes (issue 30): 10x the input costs at most 15x the time.

Each check is timed on a hostile input of size n and 10 n (best of a few runs,
since the machine is shared). The small input's time is floored at
``FLOOR`` seconds, so noise on a fast check cannot fail the test, while the
quadratic checks of before (a 40,000-deep glTF node chain, a JSON string of
escaped quotes) take far longer than 15 floors at 10 n.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable

import pytest

from conformorph.pipelines.json_depth import json_depth, without_strings
from conformorph.pipelines.landmark_document import document_mesh_count, parse_landmark_json
from conformorph.pipelines.mesh_file_checks.gltf import check_glb, check_gltf_document
from conformorph.pipelines.mesh_io import MeshLimits
from conformorph.pipelines.upload_validation import validate_mesh_upload, validate_shape_upload
from tests.fixtures.malformed_corpus import _disk, _glb, _glb_parts, _gltf_doc, _svg
from tests.fixtures.super_linear import chain_nodes, escaped_quotes

#: seconds below which the small input's time counts as this much (noise on a loaded machine)
FLOOR = 0.08
#: most the time may grow when the input grows 10x
RATIO = 15.0
LIMITS = MeshLimits(max_vertices=500_000, max_faces=1_000_000)


def _best(fn: Callable[[], object], runs: int = 3) -> float:
    best = float("inf")
    for _ in range(runs):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def _glb_chain(n: int, cycle: bool = False) -> bytes:
    doc, binary = _glb_parts(*_disk())
    return _glb(doc | {"nodes": chain_nodes(n, cycle=cycle)}, binary)


def _gltf_chain(n: int) -> bytes:
    return json.dumps(_gltf_doc(*_disk()) | {"nodes": chain_nodes(n, cycle=False)}).encode()


def _landmark_check(n: int) -> Callable[[], object]:
    doc = {"landmarks": [[k for k in range(n)], [k for k in range(n)]], "n": '\\"' * n}
    text = json.dumps(doc)

    def check() -> object:
        data = json.loads(text)
        return parse_landmark_json(data, document_mesh_count(data) or 2)

    return check


def _svg_polyline(n: int) -> bytes:
    return _svg("M0,0 " + " ".join(f"L{k % 97},{k // 97 + 1}" for k in range(n)) + " Z").encode()


#: name -> (input size n, a function making the check of an input of size n)
CHECKS: dict[str, tuple[int, Callable[[int], Callable[[], object]]]] = {
    "json_depth escaped quotes": (6_000, lambda n: lambda: json_depth(escaped_quotes(n))),
    "without_strings many strings": (
        20_000,
        lambda n: lambda: without_strings(json.dumps([f'a"{k}' for k in range(n)])),
    ),
    "shape JSON escaped quotes": (
        6_000,
        lambda n: lambda: validate_shape_upload(escaped_quotes(n).encode(), ".json"),
    ),
    "glTF escaped quotes": (
        6_000,
        lambda n: lambda: validate_mesh_upload(escaped_quotes(n).encode(), "gltf", LIMITS),
    ),
    "GLB node chain": (1_500, lambda n: lambda: check_glb(_glb_chain(n), LIMITS)),
    "GLB node chain then a cycle": (
        1_500,
        lambda n: lambda: validate_mesh_upload(_glb_chain(n, cycle=True), "glb", LIMITS),
    ),
    "glTF node chain": (
        1_500,
        lambda n: lambda: check_gltf_document(_gltf_chain(n), "GLTF", LIMITS),
    ),
    "GLB upload validation, node chain": (
        1_500,
        lambda n: lambda: validate_mesh_upload(_glb_chain(n), "glb", LIMITS),
    ),
    "SVG polyline": (1_000, lambda n: lambda: validate_shape_upload(_svg_polyline(n), ".svg")),
    "SVG unclosed entity declarations": (
        3_000,
        lambda n: (
            lambda: validate_shape_upload(("<svg>" + "<!ENTITY " * n + "</svg>").encode(), ".svg")
        ),
    ),
    "landmark document": (2_000, _landmark_check),
}


@pytest.mark.parametrize("name", sorted(CHECKS))
def test_a_check_is_linear_in_its_input(name: str) -> None:
    n, make = CHECKS[name]
    small, large = make(n), make(10 * n)
    small()  # warm up: imports, first parse
    t_small = _best(small)
    t_large = _best(large, runs=2)
    assert t_large <= RATIO * max(t_small, FLOOR), (
        f"{name}: {t_small:.3f} s at n={n}, {t_large:.3f} s at 10 n (more than {RATIO:g}x "
        f"{max(t_small, FLOOR):.3f} s)"
    )


def test_without_strings_keeps_brackets_outside_strings_only() -> None:
    text = '{"a\\"[": [1, "]]"], "b": {"c": "\\\\"}, "d": []}'
    assert without_strings(text) == '{"": [1, ""], "": {"": ""}, "": []}'
    assert json_depth(text) == 2
    assert json_depth('[["[[[", {"x": "\\\\"}]]') == 3
    assert without_strings('[1, "unterminated [[[') == '[1, ""'


def test_a_cycle_at_the_end_of_a_long_chain_is_still_found() -> None:
    out = validate_mesh_upload(_glb_chain(5_000, cycle=True), "glb", LIMITS)
    assert out["ok"] is False
    assert "nodes[5000] is its own ancestor" in out["error"]["message"]
    assert validate_mesh_upload(_glb_chain(5_000), "glb", LIMITS)["ok"] is True
