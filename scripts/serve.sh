#!/usr/bin/env bash
# Install conformorph into ./.venv and start the service on the embedded default:
# the API plus a real Celery worker on a broker and job store that need no
# server, all state under ./data (or $CONFORMORPH_DATA_DIR / --data-dir).
# Usage: bash scripts/serve.sh [--host 127.0.0.1] [--port 8000] [--data-dir DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
# the repository's ./data unless the caller chose (--data-dir wins over both);
# `conformorph` itself defaults to ~/.local/share/conformorph
export CONFORMORPH_DATA_DIR="${CONFORMORPH_DATA_DIR:-$PWD/data}"
PYTHON=${PYTHON:-python3}
if [ ! -x .venv/bin/python ]; then
  "$PYTHON" -m venv .venv
fi
.venv/bin/python -m pip install --quiet --upgrade pip
# the client is its own distribution (conformorph_client/pyproject.toml), which the server needs
.venv/bin/python -m pip install --quiet -e ./conformorph_client -e .
# automatic face landmarks (conformorph landmarks): mediapipe without its heavy
# dependencies, and embreex (scripts/install_landmarks.sh says why)
bash scripts/install_landmarks.sh .venv/bin/python >/dev/null \
  || echo "landmark detection could not be installed: 'conformorph landmarks' and its tests are unavailable" >&2
# the browser viewer served at /: three.js from npm, bundled into service/static
if command -v npm >/dev/null 2>&1; then
  npm install --no-audit --no-fund --loglevel=error >/dev/null
  npm run --silent build:viewer
else
  echo "npm not found: the browser viewer at / is not built" >&2
fi
exec .venv/bin/conformorph serve "$@"
