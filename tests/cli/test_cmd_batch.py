"""``conformorph batch`` against a live embedded server: results, resuming, failures."""

from __future__ import annotations

import inspect
import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from conformorph.cli import cmd_batch
from conformorph.cli.cmd_batch import STATE_FILE, load_manifest
from conformorph.cli.main import main
from conformorph_client import Client
from tests.live_server import ROOT, LiveServer, serve_fixture, small_face_pair

pytestmark = pytest.mark.timeout(300)


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[LiveServer]:
    yield from serve_fixture(tmp_path_factory.mktemp("batch-server"), workers=2)


@pytest.fixture
def inputs(tmp_path: Path) -> Path:
    """A folder with the small face pair and its landmarks (paths in manifests are relative)."""
    small_face_pair(tmp_path / "in")
    return tmp_path / "in"


def _manifest(folder: Path, jobs: list[dict[str, Any]], name: str = "m.json") -> Path:
    path = folder / name
    if name.endswith(".json"):
        path.write_text(json.dumps({"jobs": jobs}))
    else:
        import yaml

        path.write_text(yaml.safe_dump({"jobs": jobs}))
    return path


def _morph(name: str, frames: int, **kw: Any) -> dict[str, Any]:
    return {
        "name": name,
        "meshes": ["face_a.obj", "face_b.obj"],
        "landmarks": "landmarks.json",
        "frames": frames,
        **kw,
    }


def _total_jobs(server: LiveServer) -> int:
    with Client(server.url) as c:
        return c.list_jobs(limit=1).total


def _state(out: Path) -> dict[str, Any]:
    state: dict[str, Any] = json.loads((out / STATE_FILE).read_text())
    return state


def test_batch_runs_skips_on_rerun_and_uploads_nothing_twice(
    server: LiveServer, inputs: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    jobs = [
        _morph("m4", 4),
        _morph("m5-mt", 5, method="mt"),
        {"name": "disk", "kind": "conformal_map", "meshes": ["face_a.obj"]},
    ]
    manifest = _manifest(inputs, jobs)
    out = tmp_path / "out"
    before = _total_jobs(server)
    argv = ["batch", str(manifest), "--server", server.url, "-o", str(out), "--parallel", "3"]
    assert main(argv) == 0, capsys.readouterr().err
    text = capsys.readouterr().out
    for j in jobs:
        assert j["name"] in text
    assert "done 3, skipped 0, failed 0; uploads 2" in text  # face_a shared by 3 jobs
    for name in ("m4", "m5-mt"):
        assert (out / name / "animation.glb").read_bytes()[:4] == b"glTF"
        assert json.loads((out / name / "metrics.json").read_text())
        assert json.loads((out / name / "job.json").read_text())["state"] == "succeeded"
    assert json.loads((out / "m5-mt" / "job.json").read_text())["params"]["method"] == "mt"
    assert (out / "disk" / "disk_map.npz").is_file()
    assert _total_jobs(server) == before + 3
    state = _state(out)
    assert len(state["uploads"]) == 2
    assert {j["status"] for j in state["jobs"].values()} == {"done"}

    # the same command again: nothing uploaded, nothing submitted
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "done 0, skipped 3, failed 0; uploads 0" in text
    assert _total_jobs(server) == before + 3

    # a deleted result is fetched again; an edited entry becomes a new job
    (out / "m4" / "animation.glb").unlink()
    jobs[1]["frames"] = 6
    _manifest(inputs, jobs)
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "done 2, skipped 1, failed 0; uploads 0" in text
    assert (out / "m4" / "animation.glb").is_file()
    assert json.loads((out / "m5-mt" / "job.json").read_text())["params"]["frames"] == 6
    # m4's job was found again by its idempotency key, not run a second time
    assert _total_jobs(server) == before + 4


def test_interrupted_batch_resumes_without_redoing_finished_jobs(
    server: LiveServer, inputs: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # frame counts unused by the other tests: an identical request would be the same job
    jobs = [_morph(f"j{i}", 10 + i) for i in range(5)]
    manifest = _manifest(inputs, jobs, "m.yaml")
    out = tmp_path / "out"
    before = _total_jobs(server)
    argv = ["batch", str(manifest), "--server", server.url, "-o", str(out), "--parallel", "1"]
    proc = subprocess.Popen(
        [sys.executable, "-m", "conformorph.cli", *argv],
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    deadline = time.monotonic() + 120
    done_before: dict[str, str] = {}
    try:
        while time.monotonic() < deadline and proc.poll() is None:
            try:
                st = _state(out)
            except (FileNotFoundError, json.JSONDecodeError):
                st = {"jobs": {}}
            done_before = {
                k: v["job_id"] for k, v in st["jobs"].items() if v.get("status") == "done"
            }
            if len(done_before) >= 2:
                break
            time.sleep(0.05)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)  # an interruption without any clean-up
        proc.wait()
    assert 2 <= len(done_before) < len(jobs), "the batch was not interrupted halfway"
    rc = main(argv)
    text = capsys.readouterr().out
    assert rc == 0
    assert f"skipped {len(done_before)}" in text and "uploads 0" in text
    state = _state(out)
    for name, job_id in done_before.items():
        assert state["jobs"][name]["job_id"] == job_id  # not redone
    # every manifest job ran exactly once on the server
    assert _total_jobs(server) == before + len(jobs)
    assert len({v["job_id"] for v in state["jobs"].values()}) == len(jobs)
    for j in jobs:
        assert (out / j["name"] / "animation.glb").is_file()


def test_failed_jobs_give_exit_1_with_reasons_and_are_not_resubmitted(
    server: LiveServer, inputs: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (inputs / "bad.json").write_text(json.dumps({"landmarks": [[0, 1, 99999], [0, 1, 2]]}))
    jobs = [_morph("good", 20), {**_morph("bad", 3), "landmarks": "bad.json"}]
    manifest = _manifest(inputs, jobs)
    out = tmp_path / "out"
    argv = ["batch", str(manifest), "--server", server.url, "-o", str(out), "-q"]
    before = _total_jobs(server)
    assert main(argv) == 1
    captured = capsys.readouterr()
    assert "done 1, skipped 0, failed 1" in captured.out
    assert "bad:" in captured.err and "99999" in captured.err
    assert (out / "good" / "animation.glb").is_file() and not (out / "bad").exists()
    assert main(argv) == 1
    captured = capsys.readouterr()
    assert "done 0, skipped 1, failed 1" in captured.out and "99999" in captured.err
    assert _total_jobs(server) == before + 2
    assert main([*argv, "--retry-failed"]) == 1
    capsys.readouterr()
    assert _total_jobs(server) == before + 3


@pytest.mark.parametrize(
    ("jobs", "message"),
    [
        ([{"meshes": ["face_a.obj"]}], "'name'"),
        ([_morph("x", 3), _morph("x", 4)], "duplicate name"),
        ([{**_morph("x", 3), "meshes": ["face_a.obj", "nope.obj"]}], "no such mesh file"),
        ([{**_morph("x", 3), "framez": 3}], "unknown keys"),
        ([{"name": "d", "kind": "conformal_map", "meshes": ["face_a.obj", "face_b.obj"]}], "one"),
        ([{"name": "../up", "meshes": ["face_a.obj"]}], "'name'"),
        ([], "at least one job"),
    ],
)
def test_bad_manifests_exit_2(
    jobs: list[dict[str, Any]],
    message: str,
    inputs: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    manifest = _manifest(inputs, jobs)
    rc = main(["batch", str(manifest), "--server", "http://127.0.0.1:9", "-o", str(tmp_path)])
    err = capsys.readouterr().err
    assert rc == 2 and message in err and "Traceback" not in err


def test_manifest_paths_are_relative_to_the_manifest(inputs: Path) -> None:
    specs = load_manifest(_manifest(inputs, [_morph("a", 3, method="linear")], "m.yml"))
    assert specs[0].meshes == ((inputs / "face_a.obj").resolve(), (inputs / "face_b.obj").resolve())
    assert specs[0].params == {"frames": 3, "method": "linear"}
    assert specs[0].landmarks is not None and len(specs[0].landmarks) == 2


def test_manifest_takes_every_option_of_the_api(inputs: Path) -> None:
    """Repairs, explicit frame times, refine and normals reach the job specs."""
    jobs = [
        _morph("m", 3, refine="none", normals=True, fill_holes=True, remove_ears=True, units="mm"),
        {**_morph("t", 3, frame_times=[0, 0.5, 1.5]), "frames": None},
        {
            "name": "c",
            "kind": "conformal_map",
            "meshes": ["face_a.obj"],
            "remove_ears": True,
            "prepare": "auto",
            "vertex_budget": 20000,
        },
        {"name": "r", "kind": "reconstruction", "meshes": ["face_a.obj"], "fill_holes": True},
    ]
    specs = {s.name: s for s in load_manifest(_manifest(inputs, jobs))}
    assert specs["m"].params == {
        "frames": 3,
        "refine": "none",
        "normals": True,
        "fill_holes": True,
        "remove_ears": True,
        "units": "mm",
    }
    assert specs["t"].params == {"frame_times": [0, 0.5, 1.5]}
    assert specs["c"].params == {"remove_ears": True, "prepare": "auto", "vertex_budget": 20000}
    assert specs["r"].params == {"fill_holes": True}


def test_manifest_keys_are_the_client_options_of_each_kind() -> None:
    """A job's manifest keys are its API request's options (the client method's keywords),
    all of them but the inputs given by id and what batch sets itself."""
    from conformorph_client import _calls

    not_in_manifests = {"idempotency_key", "extra", "landmarks_id", "textures", "texture"}
    kinds = {
        "morph": (_calls.create_morph, cmd_batch._MORPH_KEYS | {"landmarks"}),
        "morph2d": (_calls.create_morph2d, cmd_batch._MORPH2D_KEYS | {"anchors"}),
        **{
            kind: (getattr(_calls, f"create_{kind}"), keys)
            for kind, keys in cmd_batch._SINGLE_KEYS.items()
        },
    }
    for kind, (builder, keys) in kinds.items():
        options = {
            name
            for name, p in inspect.signature(builder).parameters.items()
            if p.kind is inspect.Parameter.KEYWORD_ONLY
        }
        assert keys == options - not_in_manifests, kind


def test_batch_runs_2d_morphs(
    server: LiveServer, inputs: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import shutil

    shapes = ROOT / "tests" / "fixtures" / "shapes"
    for name in ("bar_straight.json", "bar_bent.json", "bar_anchors.json"):
        shutil.copy(shapes / name, inputs / name)
    job = {
        "name": "bar",
        "kind": "morph2d",
        "shapes": ["bar_straight.json", "bar_bent.json"],
        "anchors": "bar_anchors.json",
        "frames": 5,
    }
    out = tmp_path / "out"
    argv = ["batch", str(_manifest(inputs, [job])), "--server", server.url, "-o", str(out)]
    assert main(argv) == 0, capsys.readouterr().err
    assert "done 1, skipped 0, failed 0; uploads 2" in capsys.readouterr().out
    record = json.loads((out / "bar" / "job.json").read_text())
    assert record["kind"] == "morph2d" and record["params"]["frames"] == 5
    metrics = json.loads((out / "bar" / "metrics.json").read_text())
    assert metrics["methods"]["strain"]["total_flipped"] == 0
    assert (out / "bar" / "animation.glb").read_bytes()[:4] == b"glTF"
    assert main(argv) == 0
    assert "done 0, skipped 1, failed 0; uploads 0" in capsys.readouterr().out
    # the anchors are checked locally, before anything is sent
    (inputs / "one.json").write_text(json.dumps({"anchors": [[[0, 0]]]}))
    bad = _manifest(inputs, [{**job, "anchors": "one.json"}], "bad.json")
    rc = main(["batch", str(bad), "--server", server.url, "-o", str(tmp_path / "b")])
    assert rc == 2 and "anchors must be" in capsys.readouterr().err
    # without "anchors" the worker finds them (issue 18)
    (inputs / "sq.json").write_text(json.dumps({"rings": [[[0, 0], [1, 0], [1, 1], [0, 1]]]}))
    (inputs / "wide.json").write_text(json.dumps({"rings": [[[0, 0], [2, 0], [2, 1], [0, 1]]]}))
    auto = {"name": "auto", "kind": "morph2d", "shapes": ["sq.json", "wide.json"], "frames": 3}
    manifest = _manifest(inputs, [auto], "auto.json")
    rc = main(["batch", str(manifest), "--server", server.url, "-o", str(tmp_path / "a")])
    assert rc == 0, capsys.readouterr().err
    metrics = json.loads((tmp_path / "a" / "auto" / "metrics.json").read_text())
    assert metrics["correspondence"]["source"] == "automatic"
    assert (tmp_path / "a" / "auto" / "anchors.json").is_file()


def test_batch_waits_out_a_full_queue(
    tmp_path_factory: pytest.TempPathFactory,
    inputs: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    # the server takes one active job per key; three jobs in parallel meet 429s
    jobs = [_morph(f"q{i}", 3 + i) for i in range(3)]
    manifest = _manifest(inputs, jobs)
    for srv in serve_fixture(
        tmp_path_factory.mktemp("batch-limited"), env={"CONFORMORPH_MAX_ACTIVE_JOBS": "1"}
    ):
        with Client(srv.url) as c:
            mesh = c.upload_mesh(inputs / "face_a.obj")
            c.create_conformal_map(mesh.id)  # occupies the one slot for a moment
        out = tmp_path / "out"
        argv = ["batch", str(manifest), "--server", srv.url, "-o", str(out), "--parallel", "3"]
        assert main(argv) == 0, capsys.readouterr().err
        assert "done 3, skipped 0, failed 0" in capsys.readouterr().out
        assert _total_jobs(srv) == 4
