"""conformorph: conformal face morphing and 2D strain-field morphing, as a service.

Installed, the project's packages sit under this name: ``conformorph.geometry``
(pure numerics), ``conformorph.pipelines`` (the papers' steps), ``conformorph.worker``
(Celery), ``conformorph.service`` (the FastAPI app) and ``conformorph.cli`` (the
``conformorph`` command). In the repository they are the top-level folders of the
same names; this folder links to them (``conformorph/geometry -> ../geometry``, …) so
that a checkout imports them by the installed names too, and the wheel maps them
(``package-dir`` in ``setup.py``).
"""
