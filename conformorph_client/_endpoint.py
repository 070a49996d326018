"""One endpoint, one method on both clients: the :class:`Endpoint` descriptor.

A client class lists each endpoint once, as ``get_mesh = Endpoint(_calls.get_mesh)``,
where :func:`conformorph_client._calls.get_mesh` builds the request and its parser
(a :class:`~conformorph_client._calls.Call`). Read from a :class:`SyncExecutor`
the attribute is a plain method that sends the call and returns the parsed answer;
read from an :class:`AsyncExecutor` it is an ``async`` method doing the same with
``await``. Parameters, defaults, docstring and return type come from the builder,
so the two clients cannot drift apart.
"""

from __future__ import annotations

import inspect
import typing
from abc import ABC, abstractmethod
from collections.abc import Callable, Coroutine
from types import MethodType
from typing import Any, Concatenate, Generic, ParamSpec, TypeVar, overload

from conformorph_client._calls import Call

P = ParamSpec("P")
T = TypeVar("T")
F = TypeVar("F", bound=Callable[..., Any])


class SyncExecutor(ABC):
    """A client that sends a :class:`Call` and blocks for its answer."""

    @abstractmethod
    def _run(self, call: Call[T]) -> T:
        """Send ``call``; its parsed answer, or the typed error of an error status."""


class AsyncExecutor(ABC):
    """A client that sends a :class:`Call` with ``await``."""

    @abstractmethod
    async def _run(self, call: Call[T]) -> T:
        """Send ``call``; its parsed answer, or the typed error of an error status."""


def _answer_type(build: Callable[..., Any]) -> Any:
    """``X`` of a builder annotated ``-> Call[X]`` (what the client method returns)."""
    hint = typing.get_type_hints(build)["return"]
    return typing.get_args(hint)[0]


class Endpoint(Generic[P, T]):
    """The client method of one endpoint, made from the builder of its :class:`Call`.

    Parameters
    ----------
    build : callable
        Takes the method's parameters (the same names, defaults and kinds) and
        returns the call to send.
    """

    def __init__(self, build: Callable[P, Call[T]]) -> None:
        sig = inspect.signature(build)
        client = inspect.Parameter("self", inspect.Parameter.POSITIONAL_ONLY)
        signature = sig.replace(
            parameters=[client, *sig.parameters.values()], return_annotation=_answer_type(build)
        )

        def sync_method(client: SyncExecutor, /, *args: P.args, **kwargs: P.kwargs) -> T:
            return client._run(build(*args, **kwargs))

        async def async_method(client: AsyncExecutor, /, *args: P.args, **kwargs: P.kwargs) -> T:
            return await client._run(build(*args, **kwargs))

        self.__doc__ = build.__doc__
        self._sync = _dress(sync_method, build, signature)
        self._async = _dress(async_method, build, signature)

    @overload
    def __get__(self, obj: None, owner: type[Any]) -> Callable[Concatenate[Any, P], Any]: ...

    @overload
    def __get__(self, obj: SyncExecutor, owner: type[Any]) -> Callable[P, T]: ...

    @overload
    def __get__(
        self, obj: AsyncExecutor, owner: type[Any]
    ) -> Callable[P, Coroutine[Any, Any, T]]: ...

    def __get__(self, obj: object, owner: type[Any]) -> Any:
        """The plain or ``async`` method (bound to ``obj`` unless read from the class)."""
        if issubclass(owner, AsyncExecutor):
            method: Callable[..., Any] = self._async
        elif issubclass(owner, SyncExecutor):
            method = self._sync
        elif obj is None:
            return self  # read from the class that lists the endpoints
        else:
            raise TypeError(f"{owner.__name__} is neither a SyncExecutor nor an AsyncExecutor")
        return method if obj is None else MethodType(method, obj)


def _dress(method: F, build: Callable[..., Any], signature: inspect.Signature) -> F:
    """``method`` with the builder's name and docstring, and ``signature`` (the
    builder's parameters after ``self``, the answer as return type) for ``help``,
    ``inspect.signature`` and IDEs."""
    target: Any = method
    target.__name__ = target.__qualname__ = build.__name__
    target.__module__ = build.__module__
    target.__doc__ = build.__doc__
    target.__signature__ = signature
    return method
