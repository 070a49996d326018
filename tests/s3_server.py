"""A real S3-compatible HTTP endpoint for the tests: moto's server mode.

No real object store installs on these machines, so the S3 storage is tested
against ``python -m moto.server`` on a free loopback port, in its own process
(the same server as moto's ``ThreadedMotoServer``, kept out of the test
process so that the memory a test measures is the client's alone, and so that
worker processes and the API reach it over HTTP like any store). It is stopped
by its PID at the end of the session.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
import uuid
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import httpx

from tests.live_server import free_port

#: moto accepts any credentials; these are what the tests' processes are given
AWS_TEST_ENV = {
    "AWS_ACCESS_KEY_ID": "conformorph-test",
    "AWS_SECRET_ACCESS_KEY": "conformorph-test-secret",
    "AWS_DEFAULT_REGION": "us-east-1",
    # no ~/.aws files of the machine's user: the environment alone counts
    "AWS_CONFIG_FILE": "/nonexistent/conformorph-test-aws-config",
    "AWS_SHARED_CREDENTIALS_FILE": "/nonexistent/conformorph-test-aws-credentials",
}


@dataclass(frozen=True)
class S3Endpoint:
    """The running moto server: its URL, and a bucket maker."""

    url: str

    def client(self) -> Any:
        """A plain boto3 client of the server (to look at the bucket behind the storage)."""
        import boto3

        return boto3.client(
            "s3",
            endpoint_url=self.url,
            region_name=AWS_TEST_ENV["AWS_DEFAULT_REGION"],
            aws_access_key_id=AWS_TEST_ENV["AWS_ACCESS_KEY_ID"],
            aws_secret_access_key=AWS_TEST_ENV["AWS_SECRET_ACCESS_KEY"],
        )

    def new_bucket(self) -> str:
        """A fresh, empty bucket."""
        name = f"cm-test-{uuid.uuid4().hex[:12]}"
        self.client().create_bucket(Bucket=name)
        return name

    def env(self, bucket: str, prefix: str = "artifacts") -> dict[str, str]:
        """The environment that points conformorph's storage at ``bucket``."""
        return {
            **AWS_TEST_ENV,
            "CONFORMORPH_STORAGE_URL": f"s3://{bucket}/{prefix}",
            "CONFORMORPH_S3_ENDPOINT_URL": self.url,
            "CONFORMORPH_S3_ADDRESSING_STYLE": "path",
        }


def run_moto_server() -> Iterator[S3Endpoint]:
    """Body of a session fixture: moto's S3 server on a free port, killed afterwards."""
    port = free_port()
    url = f"http://127.0.0.1:{port}"
    proc = subprocess.Popen(
        [sys.executable, "-m", "moto.server", "-H", "127.0.0.1", "-p", str(port)],
        env={**os.environ, **AWS_TEST_ENV},
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        deadline = time.monotonic() + 60
        while True:
            try:
                httpx.get(f"{url}/moto-api/data.json", timeout=1)
                break
            except httpx.TransportError:
                if proc.poll() is not None or time.monotonic() > deadline:
                    raise RuntimeError("moto's S3 server did not start") from None
                time.sleep(0.1)
        yield S3Endpoint(url)
    finally:
        proc.kill()
        proc.wait()
