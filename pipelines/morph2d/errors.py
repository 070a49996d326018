"""Errors of the 2D morph pipeline and the tag naming the input an error concerns."""

from __future__ import annotations

from typing import Any


class TextureError(ValueError):
    """The texture is not a readable PNG image."""

    code = "unsupported_image"


class MorphNotConvergedError(ArithmeticError):
    """The strain morph did not reach the target shape with any strain scheme.

    ``metrics`` holds the content of the ``metrics.json`` written before the
    error was raised (every output is written, for inspection).
    """

    code = "morph_not_converged"

    def __init__(self, message: str, metrics: dict[str, Any]):
        super().__init__(message)
        self.metrics = metrics


def tag_field(exc: BaseException, field: str) -> BaseException:
    """Tag an error with the input it concerns (the API's error ``field``; see conformorph.worker.job_runner).

    Parameters
    ----------
    exc : BaseException
    field : str
        E.g. "source", "anchors[2][target]", "paths[0]", "texture".

    Returns
    -------
    BaseException
        ``exc`` itself; a tag already set is kept.
    """
    if not hasattr(exc, "conformorph_field"):
        exc.conformorph_field = field  # type: ignore[attr-defined]
    return exc
