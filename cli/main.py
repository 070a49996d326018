"""Entry point of the ``conformorph`` command.

Each command group lives in its own module exposing ``register(subparsers)``;
a handler returns an exit code. Input errors (``ValueError`` and its
subclasses, which include every ``MeshError``, ``OSError`` for unreadable
files, ``ArithmeticError`` for singular solves, and ``RecursionError`` /
``MemoryError`` from files nested too deeply or too large to parse) become
one line on stderr and exit code 2, without a traceback; any other exception
is a bug and keeps its traceback.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
from collections.abc import Sequence

COMMAND_MODULES = [
    "conformorph.cli.cmd_map",
    "conformorph.cli.cmd_morph",
    "conformorph.cli.cmd_demo",
    "conformorph.cli.cmd_serve",
    "conformorph.cli.cmd_worker",
    "conformorph.cli.cmd_keys",
    "conformorph.cli.cmd_openapi",
    "conformorph.cli.cmd_morph2d",
    "conformorph.cli.cmd_submit",
    "conformorph.cli.cmd_batch",
    "conformorph.cli.cmd_landmarks",
    "conformorph.cli.cmd_prepare",
]

#: the module registering each command; a command line naming one of them registers only
#: that module, so ``conformorph morph`` does not import the server's, the worker's or the
#: 2D morph's modules (``tests/cli/test_main_parser.py`` holds this to what they register)
COMMAND_OWNERS = {
    "map": "conformorph.cli.cmd_map",
    "reconstruct": "conformorph.cli.cmd_map",
    "morph": "conformorph.cli.cmd_morph",
    "demo": "conformorph.cli.cmd_demo",
    "serve": "conformorph.cli.cmd_serve",
    "worker": "conformorph.cli.cmd_worker",
    "keys": "conformorph.cli.cmd_keys",
    "openapi": "conformorph.cli.cmd_openapi",
    "morph2d": "conformorph.cli.cmd_morph2d",
    "submit": "conformorph.cli.cmd_submit",
    "batch": "conformorph.cli.cmd_batch",
    "landmarks": "conformorph.cli.cmd_landmarks",
    "prepare": "conformorph.cli.cmd_prepare",
}


#: BLAS thread pools are sized when numpy is first imported, i.e. while the
#: commands are registered: every command is limited before that. Workers scale by
#: process concurrency; a multi-threaded BLAS in each of them fights the others for
#: the cores (measured: 20 ICT jobs, 2 workers on 2 cores, 1.59x one worker's
#: throughput with default BLAS threads, 1.73x with one thread each). The numerics
#: use the cores through their own threads (conformorph.geometry.threads), which a BLAS pool in
#: every thread would oversubscribe (measured, benchmarks/bench_face_speed.py, two
#: ICT faces: median 2.8 s of 8 runs with default BLAS threads, 2.5 s of 5 with one).
BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def limit_blas_threads() -> None:
    """One BLAS thread per process unless the environment says otherwise."""
    for var in BLAS_THREAD_VARIABLES:
        os.environ.setdefault(var, "1")


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The argument parser with every command registered, or only ``command``'s module.

    Parameters
    ----------
    command : str, optional
        The command about to run (the first argument): when it is one of
        :data:`COMMAND_OWNERS`, only its module is imported and registered; anything
        else (``--help``, a typo) gets every command.
    """
    parser = argparse.ArgumentParser(
        prog="conformorph", description="Conformal face morphing and 2D strain-field morphing."
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    owner = COMMAND_OWNERS.get(command or "")
    for name in COMMAND_MODULES if owner is None else [owner]:
        importlib.import_module(name).register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the process exit code."""
    limit_blas_threads()
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser(argv[0] if argv else None)
    args = parser.parse_args(argv)
    try:
        return int(args.handler(args) or 0)
    except (ValueError, OSError, ArithmeticError) as exc:
        print(f"conformorph {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except (RecursionError, MemoryError) as exc:
        # a user file nested too deeply (JSON) or too large to hold: an input
        # problem, named with the parser's own words; other errors stay loud
        detail = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        print(
            f"conformorph {args.command}: error: the input is too deeply nested or too large "
            f"to process ({type(exc).__name__}: {detail})",
            file=sys.stderr,
        )
        return 2
    except KeyboardInterrupt:
        print("conformorph: interrupted", file=sys.stderr)
        return 130
