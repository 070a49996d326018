"""Terminal input and output shared by the commands: ``--times`` and ``--frames``
checks, ``--json`` printing, and rich progress bars for jobs."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any


def number_list(flag: str) -> Callable[[str], list[float]]:
    """An argparse ``type`` reading ``flag``'s comma-separated numbers as floats."""

    def parse(text: str) -> list[float]:
        try:
            return [float(x) for x in text.split(",") if x.strip()]
        except ValueError as exc:
            raise argparse.ArgumentTypeError(
                f"{flag} must be comma-separated numbers: {text!r}"
            ) from exc

    return parse


#: ``--times T0,T1,...`` (key times)
parse_times = number_list("--times")
#: ``--frame-times T,T,...`` (explicit frame times)
parse_frame_times = number_list("--frame-times")

#: ``--frame-times`` help, shared by ``morph`` and ``submit``
FRAME_TIMES_HELP = (
    "explicit frame times, strictly increasing, instead of --frames; times outside "
    "[t0, tN] extrapolate the homotopy (the paper's Table 4); write a list that starts "
    "with a minus sign as --frame-times=-0.5,0,..."
)


def check_time_flags(
    times: list[float] | None, frame_times: list[float] | None, n_keys: int
) -> None:
    """``--times`` and ``--frame-times`` against the ranges the API, the client and batch
    manifests share (:func:`conformorph.pipelines.job_fields.check_morph_times`).

    Raises
    ------
    ValueError
        Naming the flag and the entry (``--frame-times: frame_times[1] = …``): exit code 2.
    """
    from conformorph.pipelines.job_fields import FieldRangeError, check_morph_times

    try:
        check_morph_times(times, frame_times, n_keys)
    except FieldRangeError as exc:
        flag = "--frame-times" if exc.field.startswith("frame_times") else "--times"
        raise ValueError(f"{flag}: {exc}") from exc


def check_frames(frames: int | None) -> None:
    """ValueError unless ``--frames`` (when given) is at least 2."""
    if frames is not None and frames < 2:
        raise ValueError(f"--frames must be at least 2, got {frames}")


def print_json(obj: Any, indent: int | None = None) -> None:
    """``obj`` as JSON on stdout, then a newline (``--json`` output)."""
    json.dump(obj, sys.stdout, indent=indent)
    sys.stdout.write("\n")


def stage_text(job: Any) -> str:
    """``state stage (k/n)``: the job's state and current stage, by its place in the stages."""
    names = [s.name for s in job.stages]
    if job.stage in names:
        return f"{job.state} {job.stage} ({names.index(job.stage) + 1}/{len(names)})"
    return f"{job.state} (0/{len(names)})"


def use_bars(quiet: bool) -> bool:
    return not quiet and sys.stderr.isatty()


@contextmanager
def job_bars() -> Iterator[Any]:
    """A rich ``Progress`` on stderr whose tasks show a label, a bar, the percentage,
    a description (a job's stage) and the time elapsed; add tasks with a ``label``."""
    from rich.console import Console
    from rich.progress import (
        BarColumn,
        Progress,
        TaskProgressColumn,
        TextColumn,
        TimeElapsedColumn,
    )

    with Progress(
        TextColumn("{task.fields[label]}"),
        BarColumn(),
        TaskProgressColumn(),
        TextColumn("{task.description}"),
        TimeElapsedColumn(),
        console=Console(stderr=True),
    ) as progress:
        yield progress


@contextmanager
def job_progress(enabled: bool, label: str) -> Iterator[Callable[[Any], None]]:
    """A progress bar fed with job records; a no-op when disabled."""
    if not enabled:
        yield lambda job: None
        return
    with job_bars() as progress:
        task = progress.add_task("queued", total=1.0, label=label)

        def update(job: Any) -> None:
            progress.update(task, completed=job.progress, description=stage_text(job))

        yield update


@contextmanager
def stage_progress(enabled: bool, label: str) -> Iterator[Callable[[float, str], None]]:
    """A progress bar for a local command, fed with ``(fraction done, stage name)``.

    A no-op when disabled (``--quiet``, or stderr not a terminal: see :func:`use_bars`);
    the bar goes to stderr, so ``--json`` output on stdout stays clean.
    """
    if not enabled:
        yield lambda fraction, stage: None
        return
    with job_bars() as progress:
        task = progress.add_task("starting", total=1.0, label=label)

        def update(fraction: float, stage: str) -> None:
            progress.update(task, completed=min(max(float(fraction), 0.0), 1.0), description=stage)

        yield update
        progress.update(task, completed=1.0, description="done")


def add_quiet_option(p: Any) -> None:
    """``-q/--quiet`` for local commands that show a progress bar."""
    p.add_argument(
        "-q", "--quiet", action="store_true", help="no progress bar (also off when not a terminal)"
    )


def parse_vertex_budget(text: str) -> int | None:
    """``--vertex-budget N``: an integer of at least 1000, or 0 for no decimation (None).

    Parameters
    ----------
    text : str
        The flag's value.

    Returns
    -------
    int or None
    """
    from conformorph.pipelines.preparation.options import MIN_VERTEX_BUDGET

    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
    if n == 0:
        return None
    if n < MIN_VERTEX_BUDGET:
        raise argparse.ArgumentTypeError(
            f"expected 0 (never decimate) or at least {MIN_VERTEX_BUDGET}, got {n}"
        )
    return n


def parse_job_vertex_budget(text: str) -> int:
    """``submit --vertex-budget N``: the job field as sent, 0 (never decimate) or at least 1000.

    Unlike :func:`parse_vertex_budget`, 0 stays 0: the server reads a missing field as its
    default budget, so "never decimate" has to be sent.

    Parameters
    ----------
    text : str
        The flag's value.

    Returns
    -------
    int
    """
    n = parse_vertex_budget(text)
    return 0 if n is None else n


def add_cache_options(p: argparse.ArgumentParser) -> None:
    """The ``--cache DIR`` and ``--no-cache`` flags of ``morph``: where each mesh's
    per-mesh work (preparation, disk map, H, λ, detected landmarks) is kept."""
    g = p.add_mutually_exclusive_group()
    g.add_argument(
        "--cache",
        metavar="DIR",
        help="key cache folder: each mesh's preparation, disk map, curvature and conformal "
        "factor (and detected landmarks) are stored there by the file's bytes and the "
        "options, and reused by the next morph of the same file (default "
        "$XDG_CACHE_HOME/conformorph, else ~/.cache/conformorph)",
    )
    g.add_argument(
        "--no-cache", action="store_true", help="compute every mesh afresh, store nothing"
    )


def cache_dir_from_args(args: argparse.Namespace) -> str | None:
    """The key cache folder of ``--cache``/``--no-cache`` (None: no cache)."""
    from conformorph.pipelines.face_morph.key_cache import default_cache_dir

    if getattr(args, "no_cache", False):
        return None
    return str(getattr(args, "cache", None) or default_cache_dir())


def add_vertex_budget_option(p: argparse.ArgumentParser) -> None:
    """The ``--vertex-budget`` flag of ``prepare``, ``map``, ``reconstruct`` and ``morph``."""
    from conformorph.pipelines.preparation.options import DEFAULT_VERTEX_BUDGET

    p.add_argument(
        "--vertex-budget",
        type=parse_vertex_budget,
        default=DEFAULT_VERTEX_BUDGET,
        metavar="N",
        help="working resolution of the preparation step: a mesh with more vertices is "
        "decimated to about N (quadric edge collapse) and every output is at that "
        f"resolution; 0 never decimates (default {DEFAULT_VERTEX_BUDGET}; applies with "
        "--prepare auto and to 'conformorph prepare')",
    )
