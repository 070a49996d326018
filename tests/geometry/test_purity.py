"""geometry/ stays pure numerics: importing it pulls in no service, worker or I/O framework."""

import subprocess
import sys


def test_geometry_imports_no_service_worker_or_frameworks():
    code = (
        "import sys, conformorph.geometry\n"
        "bad = [m for m in sys.modules if m.removeprefix('conformorph.').split('.')[0] in "
        "('service','worker','pipelines','cli','celery','fastapi','redis','sqlalchemy','kombu','starlette')]\n"
        "print(','.join(bad))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""


def test_pipelines_import_no_celery_http_or_worker():
    """The pipelines are called by cli/ and worker/ alike: they know nothing of either."""
    code = (
        "import sys, pkgutil, importlib, conformorph.pipelines as p\n"
        "for m in pkgutil.walk_packages(p.__path__, 'conformorph.pipelines.'):\n"
        "    importlib.import_module(m.name)\n"
        "bad = [m for m in sys.modules if m.removeprefix('conformorph.').split('.')[0] in "
        "('service','worker','cli','celery','fastapi','redis','sqlalchemy','kombu','starlette')]\n"
        "print(','.join(bad))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""
