"""The ``conformorph`` command line: the only package that imports geometry, worker and service."""
