"""worker/callbacks.py: the destination allow-list (SSRF), the signature, one delivery."""

from __future__ import annotations

import hashlib
import hmac
import ipaddress
import json
import time

import pytest

from conformorph.worker.callbacks import (
    DELIVERY_HEADER,
    EVENT_HEADER,
    SIGNATURE_HEADER,
    TIMESTAMP_HEADER,
    CallbackPolicy,
    CallbackRefused,
    backoff_seconds,
    callback_body,
    check_destination,
    deliver,
    embedded_ipv4,
    parse_callback_url,
    signature,
    verify_signature,
)
from tests.webhook_receiver import webhook_receiver

LOOPBACK = CallbackPolicy.parse("public,127.0.0.0/8")
RECORD = {"id": "a" * 32, "state": "succeeded", "kind": "conformal_map"}


def _never(host: str, port: int) -> list[str]:
    raise AssertionError(f"{host} should not be resolved")


@pytest.mark.parametrize(
    "address",
    [
        "127.0.0.1",
        "127.9.9.9",
        "::1",
        "10.0.0.1",
        "172.16.5.4",
        "192.168.1.1",
        "169.254.169.254",  # the cloud metadata service
        "fe80::1",
        "fc00::1",
        "100.64.0.1",  # shared address space (carrier NAT)
        "0.0.0.0",
        "::",
        "224.0.0.1",
        "ff02::1",
        "::ffff:127.0.0.1",  # IPv4-mapped loopback
        "::ffff:10.0.0.1",
        # every IPv6 form embedding a non-public IPv4 address is judged by it (issue 30)
        "2002:7f00:1::",  # 6to4 of 127.0.0.1
        "2002:a00:1::1",  # 6to4 of 10.0.0.1
        "2002:a9fe:a9fe::",  # 6to4 of the cloud metadata service
        "2001:0:4136:e378:8000:63bf:80ff:fffe",  # Teredo, client 127.0.0.1
        "2001:0:a00:1:8000:63bf:f7f7:f7f7",  # Teredo, server 10.0.0.1, client 8.8.8.8
        "::127.0.0.1",  # IPv4-compatible (deprecated)
        "::a9fe:a9fe",
        "64:ff9b::7f00:1",  # NAT64 of 127.0.0.1
        "64:ff9b::c0a8:101",  # NAT64 of 192.168.1.1
        "64:ff9b:1::a00:1",  # local-use NAT64 of 10.0.0.1
        "240.0.0.1",
        "192.0.2.1",  # documentation
    ],
)
def test_default_policy_refuses_non_public_addresses(address: str) -> None:
    assert not CallbackPolicy.parse(None).allows_address(address)
    with pytest.raises(CallbackRefused, match="CONFORMORPH_CALLBACK_ALLOW"):
        check_destination(
            f"http://[{address}]/h" if ":" in address else f"http://{address}/h",
            CallbackPolicy(),
            _never,
        )


@pytest.mark.parametrize(
    "address",
    ["8.8.8.8", "1.1.1.1", "2606:4700:4700::1111", "2002:808:808::1", "64:ff9b::808:808"],
)
def test_default_policy_allows_public_addresses(address: str) -> None:
    assert CallbackPolicy.parse("").allows_address(address)


def test_policy_entries() -> None:
    p = CallbackPolicy.parse(" 127.0.0.0/8 , Hooks.Example.COM., 10.1.2.3, public ")
    assert p.public and p.hosts == frozenset({"hooks.example.com"})
    assert p.allows_address("127.0.0.5") and p.allows_address("10.1.2.3")
    assert not p.allows_address("10.1.2.4") and p.allows_address("8.8.8.8")
    only_net = CallbackPolicy.parse("10.0.0.0/8")
    assert not only_net.public
    assert not only_net.allows_address("8.8.8.8") and only_net.allows_address("10.9.9.9")
    assert CallbackPolicy.parse("::1").allows_address("::1")
    with pytest.raises(ValueError, match="not a host or network"):
        CallbackPolicy.parse("http://x/")


@pytest.mark.parametrize(
    ("url", "why"),
    [
        ("ftp://example.com/x", "http or https"),
        ("file:///etc/passwd", "http or https"),
        ("gopher://8.8.8.8/", "http or https"),
        ("https:///nohost", "no host"),
        ("http://user:pw@8.8.8.8/", "user info"),
        ("http://8.8.8.8:99999/", "bad port"),
        ("http://8.8.8.8/a b", "spaces"),
        ("", "1-2048"),
        ("http://x/" + "a" * 2048, "1-2048"),
        # urlsplit's own ValueError is a refusal, not a crash (issue 30)
        ("http://[::1", "not a valid URL"),
        ("http://[", "not a valid URL"),
        ("https://[x]", "not a valid URL"),
        ("http://]", "not a valid URL"),
        ("https://[8.8.8.8]/", "not a valid URL"),
    ],
)
def test_malformed_urls_are_refused(url: str, why: str) -> None:
    with pytest.raises(CallbackRefused, match=why):
        parse_callback_url(url)


def test_names_are_resolved_and_every_address_checked() -> None:
    def resolver(host: str, port: int) -> list[str]:
        assert port == 443
        return {"ok.test": ["8.8.8.8"], "split.test": ["8.8.8.8", "10.0.0.7"]}[host]

    assert check_destination("https://ok.test/h", CallbackPolicy(), resolver) == ["8.8.8.8"]
    # one private address among the answers is enough to refuse (DNS rebinding)
    with pytest.raises(CallbackRefused, match="10.0.0.7"):
        check_destination("https://split.test/h", CallbackPolicy(), resolver)

    def fails(host: str, port: int) -> list[str]:
        raise OSError("Name or service not known")

    with pytest.raises(CallbackRefused, match="does not resolve"):
        check_destination("http://nowhere.test/", CallbackPolicy(), fails)
    # a host named in the policy is allowed as it is, without resolving
    named = CallbackPolicy.parse("hooks.internal")
    assert check_destination("http://HOOKS.internal:81/x", named, _never) == []


def test_signature_hand_worked() -> None:
    # the signed bytes are exactly "<timestamp>." + body (the primitive is checked
    # against RFC 4231 below)
    body, ts = b'{"id":"x"}', "1700000000"
    expected = hmac.new(b"s3cret", b'1700000000.{"id":"x"}', hashlib.sha256).hexdigest()
    assert signature("s3cret", ts, body) == "sha256=" + expected
    assert verify_signature("s3cret", ts, body, "sha256=" + expected, now=1700000010)
    assert not verify_signature("s3cret", ts, body + b" ", "sha256=" + expected, now=1700000010)
    assert not verify_signature("other", ts, body, "sha256=" + expected, now=1700000010)
    assert not verify_signature("s3cret", ts, body, "sha256=" + expected, now=1700001000)
    assert not verify_signature("s3cret", "nan-ish", body, "sha256=" + expected)


def test_rfc4231_vector_through_hmac() -> None:
    # the primitive itself: RFC 4231 test case 2
    mac = hmac.new(b"Jefe", b"what do ya want for nothing?", hashlib.sha256).hexdigest()
    assert mac == "5bdcc146bf60754e6a042426089575c75a003f089d2739839dec58b964ec3843"


def test_backoff_doubles() -> None:
    assert [backoff_seconds(n, 2.0) for n in (1, 2, 3, 4)] == [2.0, 4.0, 8.0, 16.0]
    assert backoff_seconds(30, 2.0, cap=60.0) == 60.0
    with pytest.raises(ValueError, match="at least 1"):
        backoff_seconds(0, 2.0)


def test_delivery_is_signed_and_verifiable() -> None:
    with webhook_receiver() as rx:
        a = deliver(rx.url, RECORD, secret="a-long-enough-secret", policy=LOOPBACK)
        assert (a.outcome, a.status_code, a.error) == ("delivered", 200, None)
        (got,) = rx.wait_for(1)
    assert json.loads(got.body) == RECORD and got.body == callback_body(RECORD)
    h = got.headers
    assert h[EVENT_HEADER] == "job.succeeded" and h[DELIVERY_HEADER] == "a" * 32 + ".succeeded"
    assert h["Content-Type"] == "application/json"
    assert verify_signature(
        "a-long-enough-secret", h[TIMESTAMP_HEADER], got.body, h[SIGNATURE_HEADER]
    )


def test_unsigned_without_secret() -> None:
    with webhook_receiver() as rx:
        assert deliver(rx.url, RECORD, secret=None, policy=LOOPBACK).outcome == "delivered"
        (got,) = rx.wait_for(1)
    assert SIGNATURE_HEADER not in got.headers and TIMESTAMP_HEADER not in got.headers


@pytest.mark.parametrize(
    ("status", "outcome"),
    [
        (503, "retry"),
        (500, "retry"),
        (429, "retry"),
        (408, "retry"),
        (404, "refused"),
        (400, "refused"),
        (204, "delivered"),
    ],
)
def test_status_outcomes(status: int, outcome: str) -> None:
    with webhook_receiver([status]) as rx:
        a = deliver(rx.url, RECORD, secret=None, policy=LOOPBACK)
    assert (a.outcome, a.status_code) == (outcome, status)


def test_redirects_are_not_followed() -> None:
    with webhook_receiver([302]) as rx:
        a = deliver(rx.url, RECORD, secret=None, policy=LOOPBACK)
        assert (a.outcome, a.status_code, a.error) == ("refused", 302, "redirect not followed")
        assert [r.path for r in rx.requests] == ["/hook"]


def test_connection_failure_is_transient() -> None:
    with webhook_receiver() as rx:
        url = rx.url
    a = deliver(url, RECORD, secret=None, policy=LOOPBACK, timeout=2.0)  # server gone
    assert a.outcome == "retry" and a.status_code is None and a.error


def test_delivery_checks_the_destination_again_and_pins_the_address() -> None:
    with webhook_receiver() as rx:
        # refused by the default policy at delivery: no request is made
        a = deliver(rx.url, RECORD, secret=None, policy=CallbackPolicy())
        assert a.outcome == "refused" and "127.0.0.1" in (a.error or "")
        # a name that resolves to a private address now is refused
        url = f"http://hooks.test:{rx.port}/hook"
        a = deliver(
            url, RECORD, secret=None, policy=CallbackPolicy(), resolve=lambda h, p: ["127.0.0.1"]
        )
        assert a.outcome == "refused"
        assert rx.requests == []
        # allowed: the request goes to the checked address, named by its Host header
        a = deliver(url, RECORD, secret=None, policy=LOOPBACK, resolve=lambda h, p: ["127.0.0.1"])
        assert a.outcome == "delivered"
        (got,) = rx.wait_for(1)
    assert got.headers["Host"] == f"hooks.test:{rx.port}"


def test_attempt_record() -> None:
    with webhook_receiver([503]) as rx:
        a = deliver(rx.url, RECORD, secret=None, policy=LOOPBACK)
    rec = a.record(2, "failed", 1700000000.123456)
    assert rec["attempt"] == 2 and rec["state"] == "failed" and rec["at"] == 1700000000.123
    assert rec["outcome"] == "retry" and rec["status_code"] == 503 and rec["error"] == "HTTP 503"
    assert rec["seconds"] >= 0


def test_embedded_ipv4_forms() -> None:
    v6 = ipaddress.IPv6Address
    v4 = ipaddress.IPv4Address
    assert embedded_ipv4(v6("2002:7f00:1::")) == [v4("127.0.0.1")]
    assert embedded_ipv4(v6("::ffff:10.1.2.3")) == [v4("10.1.2.3")]
    assert embedded_ipv4(v6("64:ff9b::8.8.4.4")) == [v4("8.8.4.4")]
    assert embedded_ipv4(v6("::192.168.0.1")) == [v4("192.168.0.1")]
    server, client = embedded_ipv4(v6("2001:0:4136:e378:8000:63bf:3fff:fdd2"))
    assert (server, client) == (v4("65.54.227.120"), v4("192.0.2.45"))
    assert embedded_ipv4(v6("::1")) == [] and embedded_ipv4(v6("::")) == []
    assert embedded_ipv4(v6("2606:4700:4700::1111")) == []
    # a listed IPv4 network allows its embedded forms; a listed IPv6 network its own addresses
    assert CallbackPolicy.parse("127.0.0.0/8").allows_address("2002:7f00:1::")
    assert CallbackPolicy.parse("2002::/16").allows_address("2002:7f00:1::")
    assert not CallbackPolicy.parse("public").allows_address("2002:7f00:1::")


def test_a_receiver_trickling_its_answer_is_cut_off_at_the_total_deadline() -> None:
    """One byte every 0.5 s never trips a per-read timeout; the attempt still ends at its
    total deadline (issue 30: one byte every 3 s held an attempt for 201 s)."""
    with webhook_receiver([200], trickle=0.5) as rx:
        t0 = time.monotonic()
        a = deliver(rx.url, RECORD, secret=None, policy=LOOPBACK, timeout=2.0)
        seconds = time.monotonic() - t0
        assert len(rx.wait_for(1)) == 1  # the POST arrived whole
    assert a.outcome == "retry" and a.status_code is None
    assert "deadline" in (a.error or "")
    assert seconds < 3.0, seconds
