"""``docker-compose.yml`` is valid, and the commands it runs work (no Docker engine here).

The API and worker commands of the compose file are run as they are written,
with the compose environment pointed at this machine's Redis and PostgreSQL;
their health checks are run too, then a whole job goes through them.
"""

from __future__ import annotations

import os
import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path

import httpx
import pytest
import yaml

from tests.conftest import ROOT, WorkerProcess

COMPOSE = ROOT / "docker-compose.yml"


def _compose() -> dict[str, object]:
    return yaml.safe_load(COMPOSE.read_text())  # type: ignore[no-any-return]


def test_compose_file_shape() -> None:
    doc = _compose()
    services = doc["services"]  # type: ignore[index]
    assert set(services) >= {"redis", "api", "worker"}  # type: ignore[arg-type]
    assert "--appendonly" in services["redis"]["command"]  # type: ignore[index]
    for name in ("redis", "api", "worker"):
        assert "healthcheck" in services[name], name  # type: ignore[index]
    assert (
        "artifacts:/data" in services["api"]["volumes"]
        and "artifacts:/data" in services["worker"]["volumes"]
    )  # type: ignore[index]


@pytest.mark.skipif(shutil.which("docker-compose") is None, reason="docker-compose not installed")
def test_compose_config_validates() -> None:
    env = {**os.environ, "POSTGRES_PASSWORD": "secret"}
    ok = subprocess.run(
        ["docker-compose", "-f", str(COMPOSE), "config", "-q"],
        env=env,
        capture_output=True,
        text=True,
    )
    assert ok.returncode == 0, ok.stderr
    env.pop("POSTGRES_PASSWORD")
    missing = subprocess.run(
        ["docker-compose", "-f", str(COMPOSE), "config", "-q"],
        env=env,
        capture_output=True,
        text=True,
    )
    assert missing.returncode != 0 and "POSTGRES_PASSWORD" in missing.stderr


def _rabbitmq_variant() -> str:
    """The compose file with its documented RabbitMQ alternative switched on."""
    lines, out, inside = COMPOSE.read_text().splitlines(), [], False
    for line in lines:
        if line.strip().startswith("# rabbitmq: "):
            inside = line.strip().startswith("# rabbitmq: begin")
            continue
        if inside or line in ("  # rabbitmq-data:",) or "# CONFORMORPH_BROKER_URL: amqp" in line:
            line = line.replace("# ", "", 1)
        elif line.startswith("  CONFORMORPH_BROKER_URL: redis"):
            line = "  # " + line.strip()
        out.append(line)
    return "\n".join(out) + "\n"


@pytest.mark.skipif(shutil.which("docker-compose") is None, reason="docker-compose not installed")
def test_compose_rabbitmq_alternative_validates(tmp_path: Path) -> None:
    variant = tmp_path / "docker-compose.yml"
    variant.write_text(_rabbitmq_variant())
    env = {**os.environ, "POSTGRES_PASSWORD": "secret", "RABBITMQ_PASSWORD": "bunny"}
    ok = subprocess.run(
        ["docker-compose", "-f", str(variant), "config"],
        env=env,
        capture_output=True,
        text=True,
    )
    assert ok.returncode == 0, ok.stderr
    doc = yaml.safe_load(ok.stdout)
    assert "rabbitmq-data:/var/lib/rabbitmq" in str(doc["services"]["rabbitmq"]["volumes"])
    assert "healthcheck" in doc["services"]["rabbitmq"]
    envs: dict[str, str] = {}
    for name in ("api", "worker"):
        envs = doc["services"][name]["environment"]
        assert envs["CONFORMORPH_BROKER_URL"] == "amqp://conformorph:bunny@rabbitmq:5672//"
        assert (
            float(envs["CONFORMORPH_AMQP_CONSUMER_TIMEOUT"])
            > float(envs["CONFORMORPH_TASK_HARD_TIME_LIMIT"]) + 60
        )
    erl = doc["services"]["rabbitmq"]["environment"]["RABBITMQ_SERVER_ADDITIONAL_ERL_ARGS"]
    ms = int(1000 * float(envs["CONFORMORPH_AMQP_CONSUMER_TIMEOUT"]))
    assert erl == f"-rabbit consumer_timeout {ms}"  # the server's is the one the check uses


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _local(cmd: list[str]) -> list[str]:
    """The compose command with its executable taken from this virtualenv."""
    exe = Path(sys.executable).parent / cmd[0]
    return [str(exe) if exe.exists() else cmd[0], *cmd[1:]]


@pytest.mark.redis
@pytest.mark.timeout(150)
def test_compose_commands_run_a_job(
    tmp_path: Path, redis_url: str, pg_url: str, small_face_path: Path
) -> None:
    services = _compose()["services"]  # type: ignore[index]
    env = {k: v for k, v in os.environ.items() if not k.startswith("CONFORMORPH_")}
    env.update({k: str(v) for k, v in services["worker"]["environment"].items()})  # type: ignore[index]
    env.update(
        CONFORMORPH_BROKER_URL=redis_url,
        CONFORMORPH_DATABASE_URL=pg_url,
        CONFORMORPH_DATA_DIR=str(tmp_path),
        PYTHONPATH=str(ROOT),
    )
    port = _free_port()
    api_cmd = [c if c != "8000" else str(port) for c in services["api"]["command"]]  # type: ignore[index]
    api_cmd = [c if c != "0.0.0.0" else "127.0.0.1" for c in api_cmd]
    api = subprocess.Popen(
        _local(api_cmd),
        env=env,
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    worker = WorkerProcess.__new__(WorkerProcess)
    worker.log = tmp_path / "worker.log"
    worker.proc = subprocess.Popen(
        _local(services["worker"]["command"]),  # type: ignore[index]
        env={**env, "HOSTNAME": socket.gethostname()},
        cwd=ROOT,
        stdout=open(worker.log, "wb"),  # noqa: SIM115
        stderr=subprocess.STDOUT,
        start_new_session=True,
    )
    try:
        base = f"http://127.0.0.1:{port}"
        deadline = time.monotonic() + 60
        while True:
            try:
                if httpx.get(f"{base}/readyz", timeout=1).status_code == 200:
                    break
            except httpx.TransportError:
                pass
            assert api.poll() is None and time.monotonic() < deadline, "api did not come up"
            time.sleep(0.2)
        api_check = [
            c.replace("8000", str(port)) for c in services["api"]["healthcheck"]["test"][1:]
        ]  # type: ignore[index]
        assert subprocess.run(_local(api_check), env=env, timeout=30).returncode == 0
        with open(small_face_path, "rb") as f:
            r = httpx.post(f"{base}/v1/meshes", files={"file": ("face.obj", f.read())}, timeout=60)
        assert r.status_code == 201, r.text
        r = httpx.post(f"{base}/v1/conformal-maps", json={"mesh": r.json()["id"]}, timeout=10)
        url = base + r.headers["location"]
        while (job := httpx.get(url, timeout=5).json())["state"] in ("queued", "running"):
            assert time.monotonic() < deadline + 30
            time.sleep(0.1)
        assert job["state"] == "succeeded", job
        check = services["worker"]["healthcheck"]["test"][1].replace(
            "$$HOSTNAME", socket.gethostname()
        )  # type: ignore[index]
        exe = str(Path(sys.executable).parent / "celery")
        out = subprocess.run(
            check.replace("celery ", exe + " ", 1),
            shell=True,
            env=env,
            cwd=ROOT,
            timeout=60,
            capture_output=True,
            text=True,
        )
        assert out.returncode == 0, out.stdout + out.stderr
    finally:
        worker.kill()
        if api.poll() is None:
            os.killpg(api.pid, 9)
            api.wait()


def _s3_variant() -> str:
    """The compose file with its documented object-storage block switched on."""
    out, inside = [], False
    for line in COMPOSE.read_text().splitlines():
        if line.strip() in ("# s3: begin", "# s3: end"):
            inside = line.strip() == "# s3: begin"
            continue
        out.append(line.replace("# ", "", 1) if inside else line)
    return "\n".join(out) + "\n"


@pytest.mark.skipif(shutil.which("docker-compose") is None, reason="docker-compose not installed")
def test_compose_s3_alternative_validates(tmp_path: Path) -> None:
    from conformorph.worker.config import WorkerSettings
    from conformorph.worker.open_storage import s3_options

    variant = tmp_path / "docker-compose.yml"
    variant.write_text(_s3_variant())
    secrets = {"AWS_ACCESS_KEY_ID": "id", "AWS_SECRET_ACCESS_KEY": "key"}
    env = {
        **{k: v for k, v in os.environ.items() if not k.startswith(("AWS_", "S3_"))},
        "POSTGRES_PASSWORD": "secret",
        "S3_BUCKET": "morphs",
        "S3_ENDPOINT_URL": "http://minio:9000",
        "CONFORMORPH_SECRET_KEY": "one key for api and workers",
        **secrets,
    }
    ok = subprocess.run(
        ["docker-compose", "-f", str(variant), "config"], env=env, capture_output=True, text=True
    )
    assert ok.returncode == 0, ok.stderr
    for name in ("api", "worker"):
        envs = yaml.safe_load(ok.stdout)["services"][name]["environment"]
        assert envs["AWS_ACCESS_KEY_ID"] == "id" and envs["AWS_DEFAULT_REGION"] == "us-east-1"
        assert envs["CONFORMORPH_SECRET_KEY"] == "one key for api and workers"
        settings = WorkerSettings(
            **{
                k.removeprefix("CONFORMORPH_").lower(): v
                for k, v in envs.items()
                if k.startswith("CONFORMORPH_")
            }
        )
        opts = s3_options(settings, str(settings.storage_url))
        assert (opts.bucket, opts.prefix) == ("morphs", "artifacts")
        assert (opts.endpoint_url, opts.downloads) == ("http://minio:9000", "proxy")
    env.pop("S3_BUCKET")
    missing = subprocess.run(
        ["docker-compose", "-f", str(variant), "config", "-q"],
        env=env,
        capture_output=True,
        text=True,
    )
    assert missing.returncode != 0 and "S3_BUCKET" in missing.stderr
