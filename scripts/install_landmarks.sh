#!/usr/bin/env bash
# Install what 'conformorph landmarks' needs into the current Python environment.
#
# mediapipe 0.10.14 ships its face detector and FaceMesh models inside the wheel
# (cp38-cp312; the 1.x releases need downloaded model files). Its declared
# dependencies pull jax, jaxlib, opencv-contrib-python and sounddevice (a 1.2 GB
# environment) that FaceMesh does not use, so it is installed without them and
# the packages it does import are installed by name. embreex is trimesh's Embree
# ray caster (the render's per-pixel triangle and barycentric coordinates).
#
# Usage: scripts/install_landmarks.sh [PYTHON]   (default: python3)
set -euo pipefail
PY="${1:-python3}"
"$PY" -m pip install --quiet "embreex>=4.4" "opencv-python-headless>=4.9" "protobuf>=4.25,<5" \
    "absl-py>=2" "attrs>=23" "flatbuffers>=24" "matplotlib>=3.8"
"$PY" -m pip install --quiet --no-deps "mediapipe==0.10.14"
"$PY" -c "import mediapipe, trimesh; assert trimesh.ray.has_embree; \
mediapipe.solutions.face_mesh.FaceMesh(static_image_mode=True, refine_landmarks=True).close(); \
print('landmark detection ready: mediapipe', mediapipe.__version__)"
