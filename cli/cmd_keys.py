"""``conformorph keys create NAME`` and ``conformorph keys list``: API keys, stored hashed."""

from __future__ import annotations

import argparse
import os
from typing import Any


def _store(args: argparse.Namespace) -> Any:
    if args.data_dir:
        os.environ["CONFORMORPH_DATA_DIR"] = str(args.data_dir)
    from conformorph.worker.config import WorkerSettings
    from conformorph.worker.job_store import JobStore

    settings = WorkerSettings()
    settings.data_dir.mkdir(parents=True, exist_ok=True)
    return JobStore(settings.resolved_database_url)


def run_create(args: argparse.Namespace) -> int:
    store = _store(args)
    kid, key = store.create_key(args.name)
    print(f"created API key {args.name!r} (id {kid}); it is shown only once:")
    print(key)
    return 0


def run_list(args: argparse.Namespace) -> int:
    from sqlalchemy import select

    from conformorph.worker.job_store import ApiKey

    store = _store(args)
    with store.session() as s:
        for k in s.scalars(select(ApiKey).order_by(ApiKey.created_at)):
            print(f"{k.id}  {k.name}")
    return 0


def register(sub: Any) -> None:
    """Add the ``keys`` command group."""
    p = sub.add_parser("keys", help="manage API keys")
    ks = p.add_subparsers(dest="keys_command", metavar="ACTION")
    ks.required = True
    c = ks.add_parser("create", help="create a key and print it (last word of the output)")
    c.add_argument("name", help="a name for the key (who uses it)")
    c.add_argument("--data-dir", help="data folder (default $CONFORMORPH_DATA_DIR)")
    c.set_defaults(handler=run_create)
    ls = ks.add_parser("list", help="list key ids and names")
    ls.add_argument("--data-dir", help="data folder (default $CONFORMORPH_DATA_DIR)")
    ls.set_defaults(handler=run_list)
