"""Celery app, tasks, job store, storage and file I/O of conformorph (no service imports)."""
