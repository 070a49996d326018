#!/usr/bin/env bash
# Install conformorph into ./.venv and start the service on the embedded default:
# the API plus a real Celery worker on a broker and job store that need no
# server, all state under ./data (or $CONFORMORPH_DATA_DIR / --data-dir).
# Usage: bash scripts/serve.sh [--host 127.0.0.1] [--port 8000] [--data-dir DIR]
#
# Installs run only when what they install from changed: a stamp in .venv holds the
# hash of the requirements (pyproject.toml, setup.py, conformorph_client/pyproject.toml,
# scripts/install_landmarks.sh), another the hash of package-lock.json, a third that of
# the viewer's sources. A second start with nothing changed goes straight to serving.
# CONFORMORPH_REINSTALL=1 installs again regardless.
set -euo pipefail
cd "$(dirname "$0")/.."
# the repository's ./data unless the caller chose (--data-dir wins over both);
# `conformorph` itself defaults to ~/.local/share/conformorph
export CONFORMORPH_DATA_DIR="${CONFORMORPH_DATA_DIR:-$PWD/data}"
PYTHON=${PYTHON:-python3}
if [ ! -x .venv/bin/python ]; then
  "$PYTHON" -m venv .venv
fi

# the hash of the files given that exist ("" when no hashing tool: then always install)
stamp_of() {
  local files=() f
  for f in "$@"; do [ -f "$f" ] && files+=("$f"); done
  if command -v sha256sum >/dev/null 2>&1 && [ "${#files[@]}" -gt 0 ]; then
    sha256sum "${files[@]}" | sha256sum | cut -d' ' -f1
  fi
}
# true when the stamp file $1 does not hold hash $2 (or there is no hash)
changed() {
  [ "${CONFORMORPH_REINSTALL:-0}" = 1 ] || [ -z "$2" ] || [ ! -f "$1" ] || [ "$(cat "$1")" != "$2" ]
}

PY_STAMP=$(stamp_of pyproject.toml setup.py conformorph_client/pyproject.toml scripts/install_landmarks.sh)
if changed .venv/.conformorph-requirements "$PY_STAMP" || [ ! -x .venv/bin/conformorph ]; then
  .venv/bin/python -m pip install --quiet --upgrade pip
  # the client is its own distribution (conformorph_client/pyproject.toml), which the server needs
  .venv/bin/python -m pip install --quiet -e ./conformorph_client -e .
  # automatic face landmarks (conformorph landmarks): mediapipe without its heavy
  # dependencies, and embreex (scripts/install_landmarks.sh says why)
  bash scripts/install_landmarks.sh .venv/bin/python >/dev/null \
    || echo "landmark detection could not be installed: 'conformorph landmarks' and its tests are unavailable" >&2
  [ -z "$PY_STAMP" ] || echo "$PY_STAMP" > .venv/.conformorph-requirements
fi
# the browser viewer served at /: three.js from npm, bundled into service/static
if command -v npm >/dev/null 2>&1; then
  NPM_STAMP=$(stamp_of package.json package-lock.json)
  if changed .venv/.conformorph-npm "$NPM_STAMP" || [ ! -d node_modules/three ]; then
    npm install --no-audit --no-fund --loglevel=error >/dev/null
    [ -z "$NPM_STAMP" ] || echo "$NPM_STAMP" > .venv/.conformorph-npm
  fi
  VIEWER_STAMP=$(stamp_of viewer/build.mjs viewer/index.html viewer/style.css viewer/favicon.svg viewer/src/*.js)
  if changed .venv/.conformorph-viewer "$VIEWER_STAMP" || [ ! -f service/static/viewer.js ]; then
    npm run --silent build:viewer
    [ -z "$VIEWER_STAMP" ] || echo "$VIEWER_STAMP" > .venv/.conformorph-viewer
  fi
else
  echo "npm not found: the browser viewer at / is not built" >&2
fi
exec .venv/bin/conformorph serve "$@"
