"""A failed job's error record carries messages written for the client (issue 15, item 12)."""

from __future__ import annotations

import numpy as np
import pytest

from conformorph.geometry.mesh_errors import NotDiskError
from conformorph.worker.job_runner import error_body


def _raised(fn):
    try:
        fn()
    except BaseException as exc:  # noqa: BLE001 - the test inspects what was raised
        return exc
    raise AssertionError("nothing raised")


def test_domain_errors_keep_their_message_and_code():
    body = error_body(NotDiskError("the mesh has 2 boundary loops;\n  a disk has 1"), "map")
    assert body == {
        "type": "not_disk",
        "message": "the mesh has 2 boundary loops; a disk has 1",
        "field": None,
        "stage": "map",
    }


def test_our_own_value_errors_keep_their_message():
    from conformorph.geometry import refine_angles

    exc = _raised(lambda: refine_angles(np.zeros((3, 3)), np.zeros((1, 3), int), None, None))
    assert error_body(exc, "map")["message"] == "uv must have shape (n, 2), got (3, 3)"


@pytest.mark.parametrize(
    "fail",
    [
        lambda: [][1],  # list index out of range
        lambda: None[0],  # type: ignore[index]  # 'NoneType' object is not subscriptable
        lambda: {}["boundary"],
        lambda: np.zeros(3) + np.zeros(4),  # numpy's own ValueError text
    ],
)
def test_library_and_bug_text_is_not_shown(fail):
    exc = _raised(fail)
    body = error_body(exc, "register")
    assert body["type"] == "internal_error"
    assert (
        body["message"]
        == "stage 'register' failed because of an internal error (logged on the worker)"
    )
    assert str(exc) not in body["message"]


def test_storage_errors_do_not_name_server_paths():
    exc = _raised(lambda: open("/srv/conformorph/data/storage/meshes/key-7/abc.obj"))
    body = error_body(exc, "map")
    assert body["type"] == "storage_error"
    assert "/srv" not in body["message"] and "key-7" not in body["message"]


# issue 30, item 8: our own codes, the API's words, no paths


def test_our_value_errors_get_a_named_code_not_a_class_name():
    from conformorph.geometry import refine_angles

    exc = _raised(lambda: refine_angles(np.zeros((3, 3)), np.zeros((1, 3), int), None, None))
    assert error_body(exc, "map")["type"] == "invalid_input"
    # built and passed around, not raised (as a stage re-raising its own): ours
    assert error_body(ArithmeticError("the solve diverged"), "frames")["type"] == (
        "numerical_failure"
    )


def test_texture_without_uvs_names_the_field_not_the_path_or_key(tmp_path):
    """The reproduction: a job's texture on a mesh without UVs said
    "<data dir>/artifacts/meshs/key-4e5c…/33ae….obj: --texture needs one texture coordinate"."""
    from conformorph.pipelines.face_morph.textures import read_texture
    from conformorph.worker.job_runner import input_field

    folder = tmp_path / "artifacts" / "meshs" / "key-4e5c0123456789ab"
    folder.mkdir(parents=True)
    mesh = folder / "33ae0123456789abcdef0123456789ab.obj"
    mesh.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")

    def run():
        with input_field("textures[1]"):
            read_texture(mesh, tmp_path / "t.png", 3)

    body = error_body(_raised(run), "prepare")
    assert body["type"] == "invalid_input" and body["field"] == "textures[1]"
    msg = body["message"]
    assert str(tmp_path) not in msg and "/" not in msg and "key-" not in msg, msg
    assert "4e5c0123456789ab" not in msg and "--" not in msg, msg
    assert msg.startswith("textures[1]: textures needs one texture coordinate per vertex"), msg


def test_api_message_hand_worked():
    from conformorph.worker.job_errors import api_message

    assert api_message("/srv/d/x.obj: bad", "meshes[0]") == "meshes[0]: bad"
    assert api_message("C:\\data\\x.ply, then --frame-times must") == (
        "the input file, then frame_times must"
    )
    assert api_message("see storage/key-0123456789abcdef/a.obj.") == "see the input file."
    assert api_message("owner key-0123456789abcdef refused") == "owner key refused"
    # fractions, ratios and words with slashes that are not files are kept
    assert api_message("1/3 of the faces; and/or --no-fold-correction") == (
        "1/3 of the faces; and/or fold_correction"
    )
    assert api_message("use --consistent-mesh landmarks") == "use consistent landmarks"
    assert api_message("see https://example.com/a.obj") == "see https://example.com/a.obj"
