"""Job webhooks: where a callback may go, how it is signed, and one delivery attempt.

A job created with ``callback_url`` gets one POST of its job record (the JSON of
``GET /v1/jobs/{id}``) when it reaches a terminal state (succeeded, failed,
cancelled). The POST is made by a worker (task ``conformorph.deliver_callback``),
never by the API process.

Signature
---------
With a ``callback_secret`` every POST carries::

    X-Conformorph-Timestamp: <unix seconds>
    X-Conformorph-Signature: sha256=<hex HMAC-SHA256(secret, "<timestamp>." + body)>

so a receiver recomputes the HMAC over the timestamp, a dot and the raw body
bytes, compares it in constant time, and refuses old timestamps (replays).
``X-Conformorph-Event`` is ``job.<state>`` and ``X-Conformorph-Delivery`` is
``<job id>.<state>`` (the same on every retry of one event: deliveries are at
least once, a receiver deduplicates by it).

Destinations (SSRF, OWASP API7)
-------------------------------
``CONFORMORPH_CALLBACK_ALLOW`` is a comma-separated allow-list of entries:

* ``public``: any globally routable address (the default when unset);
* a host name (``hooks.example.com``): that name, whatever it resolves to;
* an address or CIDR network (``127.0.0.1``, ``10.1.0.0/16``, ``fd00::/8``).

Without an entry allowing them, private, loopback, link-local (cloud metadata),
shared, reserved, multicast and unspecified addresses are refused. Only
``http`` and ``https``, no user info in the URL. The URL is checked when the job
is submitted (422) and again at each delivery after resolving the name; the
connection then goes to the checked address itself (TLS still verifies the
name), so a name that resolves elsewhere later cannot redirect it. Redirects
are never followed.
"""

from __future__ import annotations

import hashlib
import hmac
import ipaddress
import json
import socket
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any
from urllib.parse import SplitResult, urlsplit, urlunsplit

import httpcore

from conformorph.worker.deadline_http import post_status

IPAddress = ipaddress.IPv4Address | ipaddress.IPv6Address
IPNetwork = ipaddress.IPv4Network | ipaddress.IPv6Network
Resolver = Callable[[str, int], Sequence[str]]

SIGNATURE_HEADER = "X-Conformorph-Signature"
TIMESTAMP_HEADER = "X-Conformorph-Timestamp"
EVENT_HEADER = "X-Conformorph-Event"
DELIVERY_HEADER = "X-Conformorph-Delivery"
#: longest callback URL accepted
MAX_URL_LENGTH = 2048
#: HTTP statuses worth retrying; any other non-2xx answer is final
RETRY_STATUSES = frozenset({408, 425, 429, 500, 502, 503, 504})
#: failures of one attempt worth retrying: time-outs (the attempt's total deadline among
#: them), connection failures, answers that are not HTTP
TRANSIENT_ERRORS = (
    httpcore.TimeoutException,
    httpcore.NetworkError,
    httpcore.ProtocolError,
    httpcore.UnsupportedProtocol,
)


class CallbackRefused(ValueError):
    """A callback URL is malformed or its destination is not allowed."""


@dataclass(frozen=True)
class CallbackPolicy:
    """Which destinations callbacks may reach (see the module docstring).

    Attributes
    ----------
    public : bool
        Globally routable addresses are allowed.
    hosts : frozenset of str
        Host names allowed whatever they resolve to (lower case).
    networks : tuple of networks
        Addresses and networks allowed even when not public.
    """

    public: bool = True
    hosts: frozenset[str] = frozenset()
    networks: tuple[IPNetwork, ...] = ()

    @classmethod
    def parse(cls, allow: str | None) -> CallbackPolicy:
        """The policy of a ``CONFORMORPH_CALLBACK_ALLOW`` value (None or blank: ``public``).

        Raises
        ------
        ValueError
            An entry is neither ``public``, a host name nor an address/network.
        """
        entries = [e.strip() for e in (allow or "").split(",") if e.strip()]
        if not entries:
            return cls()
        public, hosts, networks = False, set(), []
        for entry in entries:
            if entry.lower() == "public":
                public = True
                continue
            try:
                networks.append(ipaddress.ip_network(entry, strict=False))
                continue
            except ValueError:
                pass
            name = entry.lower().rstrip(".")
            if not name or any(c in name for c in "/:@ []") or len(name) > 253:
                raise ValueError(f"CONFORMORPH_CALLBACK_ALLOW: {entry!r} is not a host or network")
            hosts.add(name)
        return cls(public, frozenset(hosts), tuple(networks))

    def allows_address(self, address: str) -> bool:
        """True when ``address`` (an IP literal) is a destination this policy allows.

        An IPv6 address that embeds an IPv4 one (see :func:`embedded_ipv4`) is
        judged by what it embeds, every embedded address having to be allowed,
        unless a listed IPv6 network holds the IPv6 address itself.
        """
        ip: IPAddress = ipaddress.ip_address(address.split("%", 1)[0])
        if self._listed(ip):
            return True
        embedded = embedded_ipv4(ip) if isinstance(ip, ipaddress.IPv6Address) else []
        if embedded:
            return all(
                self._listed(v4) or (self.public and is_public_address(v4)) for v4 in embedded
            )
        return self.public and is_public_address(ip)

    def _listed(self, ip: IPAddress) -> bool:
        return any(ip.version == net.version and ip in net for net in self.networks)


#: NAT64 prefixes whose last 32 bits are an IPv4 address: the well-known one (RFC 6052)
#: and the local-use one (RFC 8215)
NAT64_NETWORKS = (ipaddress.ip_network("64:ff9b::/96"), ipaddress.ip_network("64:ff9b:1::/48"))
_IPV4_COMPATIBLE = ipaddress.ip_network("::/96")


def embedded_ipv4(ip: ipaddress.IPv6Address) -> list[ipaddress.IPv4Address]:
    """The IPv4 addresses an IPv6 address carries, where a router would deliver to them.

    IPv4-mapped ``::ffff:a.b.c.d``, 6to4 ``2002:AABB:CCDD::/48``, Teredo
    ``2001::/32`` (its server and its client, both), NAT64 ``64:ff9b::a.b.c.d``
    (and the local-use ``64:ff9b:1::/48``) and the deprecated IPv4-compatible
    ``::a.b.c.d``; an empty list for any other address. ``::`` and ``::1``
    are themselves (unspecified, loopback), not IPv4-compatible forms.
    """
    if ip.ipv4_mapped is not None:
        return [ip.ipv4_mapped]
    if ip.sixtofour is not None:
        return [ip.sixtofour]
    if ip.teredo is not None:
        return list(ip.teredo)
    if any(ip in net for net in NAT64_NETWORKS):
        return [ipaddress.IPv4Address(int(ip) & 0xFFFFFFFF)]
    if ip in _IPV4_COMPATIBLE and int(ip) > 1:
        return [ipaddress.IPv4Address(int(ip) & 0xFFFFFFFF)]
    return []


def is_public_address(ip: IPAddress) -> bool:
    """True for a globally routable unicast address (not private, loopback, link-local,
    shared, reserved, multicast or unspecified)."""
    return bool(
        ip.is_global
        and not (
            ip.is_multicast
            or ip.is_private
            or ip.is_loopback
            or ip.is_link_local
            or ip.is_reserved
            or ip.is_unspecified
        )
    )


def parse_callback_url(url: str) -> SplitResult:
    """The parts of a callback URL; raises :class:`CallbackRefused` unless it is an
    absolute ``http``/``https`` URL with a host and no user info."""
    if not isinstance(url, str) or not url or len(url) > MAX_URL_LENGTH:
        raise CallbackRefused(f"callback_url must be 1-{MAX_URL_LENGTH} characters")
    if any(ord(c) < 0x21 or ord(c) == 0x7F for c in url):
        raise CallbackRefused("callback_url must not contain spaces or control characters")
    try:
        parts = urlsplit(url)
        parts.hostname  # noqa: B018 - raises ValueError on a bad bracketed host
    except ValueError as exc:  # "http://[::1", "https://[x]", "http://]"
        raise CallbackRefused(f"callback_url is not a valid URL: {exc}") from None
    if parts.scheme not in ("http", "https"):
        raise CallbackRefused("callback_url must be an http or https URL")
    if not parts.hostname:
        raise CallbackRefused("callback_url has no host")
    if parts.username is not None or parts.password is not None:
        raise CallbackRefused("callback_url must not carry user info (use callback_secret)")
    try:
        parts.port  # noqa: B018 - raises ValueError on a bad port
    except ValueError as exc:
        raise CallbackRefused(f"callback_url has a bad port: {exc}") from exc
    return parts


def system_resolver(host: str, port: int) -> list[str]:
    """Every address ``host`` resolves to (``getaddrinfo``, TCP)."""
    infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)
    return sorted({str(info[4][0]) for info in infos})


def _default_port(parts: SplitResult) -> int:
    return parts.port or (443 if parts.scheme == "https" else 80)


def check_destination(
    url: str, policy: CallbackPolicy, resolve: Resolver = system_resolver
) -> list[str]:
    """The addresses ``url`` may be delivered to under ``policy``.

    A host named in the policy is allowed as it is (returns ``[]``: connect by
    name). Otherwise the host (an address, or a name resolved with ``resolve``)
    must have every one of its addresses allowed.

    Raises
    ------
    CallbackRefused
        The URL is malformed, its name does not resolve, or one of its addresses
        is not allowed.
    """
    parts = parse_callback_url(url)
    host = (parts.hostname or "").lower().rstrip(".")
    if host in policy.hosts:
        return []
    try:
        addresses = [str(ipaddress.ip_address(host))]
    except ValueError:
        try:
            addresses = list(resolve(host, _default_port(parts)))
        except (OSError, UnicodeError) as exc:
            raise CallbackRefused(f"callback_url host {host!r} does not resolve: {exc}") from exc
    if not addresses:
        raise CallbackRefused(f"callback_url host {host!r} does not resolve")
    refused = [a for a in addresses if not policy.allows_address(a)]
    if refused:
        raise CallbackRefused(
            f"callback_url host {host!r} is {', '.join(refused)}: private, loopback, "
            "link-local, multicast and other non-public addresses are refused unless "
            "CONFORMORPH_CALLBACK_ALLOW lists them"
        )
    return addresses


def signature(secret: str, timestamp: str, body: bytes) -> str:
    """``sha256=<hex>``: HMAC-SHA256 of ``"<timestamp>." + body`` keyed with ``secret``."""
    mac = hmac.new(secret.encode(), timestamp.encode() + b"." + body, hashlib.sha256)
    return "sha256=" + mac.hexdigest()


def verify_signature(
    secret: str,
    timestamp: str,
    body: bytes,
    header: str,
    *,
    tolerance: float = 300.0,
    now: float | None = None,
) -> bool:
    """What a receiver does: True when ``header`` signs ``body`` at ``timestamp`` with
    ``secret`` and the timestamp is within ``tolerance`` seconds of ``now``."""
    try:
        ts = float(timestamp)
    except ValueError:
        return False
    if abs((time.time() if now is None else now) - ts) > tolerance:
        return False
    return hmac.compare_digest(signature(secret, timestamp, body), header)


def callback_body(record: dict[str, Any]) -> bytes:
    """The POST body: the job record as compact JSON (UTF-8)."""
    return json.dumps(record, sort_keys=True, separators=(",", ":")).encode()


@dataclass(frozen=True)
class Attempt:
    """One delivery attempt.

    ``outcome`` is ``delivered`` (a 2xx answer), ``retry`` (a transient failure:
    connection error, time-out, 408/425/429/5xx) or ``refused`` (final: another
    answer, a redirect, or a destination no longer allowed).
    """

    outcome: str
    status_code: int | None
    error: str | None
    seconds: float

    def record(self, number: int, state: str, at: float) -> dict[str, Any]:
        """The attempt as recorded on the job."""
        return {
            "attempt": number,
            "at": round(at, 3),
            "state": state,
            "outcome": self.outcome,
            "status_code": self.status_code,
            "error": self.error,
            "seconds": round(self.seconds, 4),
        }


def _pinned_request(parts: SplitResult, address: str | None) -> tuple[str, dict[str, str], dict]:
    """URL, extra headers and httpx extensions that connect to ``address`` while
    naming the URL's host (``Host`` header, TLS SNI and certificate check)."""
    if address is None:
        return urlunsplit(parts), {}, {}
    host = parts.hostname or ""
    literal = f"[{address}]" if ":" in address else address
    netloc = f"{literal}:{parts.port}" if parts.port else literal
    url = urlunsplit(parts._replace(netloc=netloc))
    host_header = f"{host}:{parts.port}" if parts.port else host
    extensions = {"sni_hostname": host} if parts.scheme == "https" else {}
    return url, {"Host": host_header}, extensions


def deliver(
    url: str,
    record: dict[str, Any],
    *,
    secret: str | None,
    policy: CallbackPolicy,
    timeout: float = 10.0,
    resolve: Resolver = system_resolver,
    now: Callable[[], float] = time.time,
) -> Attempt:
    """POST ``record`` to ``url`` once, checked against ``policy`` after resolving.

    ``timeout`` is the attempt's total deadline in seconds: connecting, TLS,
    sending and reading the answer together (a receiver trickling its answer
    byte by byte is cut off then, :mod:`conformorph.worker.deadline_http`).
    Never raises for a network failure: every outcome is an :class:`Attempt`.
    """
    t0 = time.perf_counter()
    try:
        addresses = check_destination(url, policy, resolve)
    except CallbackRefused as exc:
        return Attempt("refused", None, str(exc), time.perf_counter() - t0)
    body = callback_body(record)
    state = str(record.get("state"))
    headers = {
        "Content-Type": "application/json",
        "User-Agent": "conformorph-webhook/1",
        EVENT_HEADER: f"job.{state}",
        DELIVERY_HEADER: f"{record.get('id')}.{state}",
    }
    if secret:
        ts = str(int(now()))
        headers[TIMESTAMP_HEADER] = ts
        headers[SIGNATURE_HEADER] = signature(secret, ts, body)
    target, extra, extensions = _pinned_request(
        parse_callback_url(url), addresses[0] if addresses else None
    )
    try:
        status = post_status(
            target,
            body,
            {**headers, **extra},
            deadline_seconds=timeout,
            sni_hostname=extensions.get("sni_hostname"),
        )
    except TRANSIENT_ERRORS as exc:
        return Attempt(
            "retry", None, f"{type(exc).__name__}: {exc}"[:500], time.perf_counter() - t0
        )
    seconds = time.perf_counter() - t0
    if 200 <= status < 300:
        return Attempt("delivered", status, None, seconds)
    if status in RETRY_STATUSES:
        return Attempt("retry", status, f"HTTP {status}", seconds)
    why = "redirect not followed" if 300 <= status < 400 else f"HTTP {status}"
    return Attempt("refused", status, why, seconds)


def backoff_seconds(attempt: int, base: float, cap: float = 3600.0) -> float:
    """Wait before retry number ``attempt`` (1-based): ``base * 2**(attempt-1)``, capped."""
    if attempt < 1:
        raise ValueError(f"attempt must be at least 1, got {attempt}")
    return float(min(cap, base * 2.0 ** (attempt - 1)))
