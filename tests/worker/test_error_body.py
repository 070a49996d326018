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
