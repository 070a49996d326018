"""The papers' pipelines as named steps, between :mod:`geometry` and its callers.

:mod:`geometry` holds the pure numerics (arrays in, arrays out). This package
composes them into what users run — the face morph (Yueh et al.), the 2D
strain-field morph (Yan, Hu, Martin), the disk conformal map and the surface
reconstruction — and reads and writes the files they take and give (meshes,
shapes, landmark and anchor files, textures, glTF). It knows nothing of
Celery or HTTP: ``cli/`` calls it in-process and ``worker/`` calls it from one
thin task per stage.

Importing this package is cheap; each module imports its numerics itself.
"""
