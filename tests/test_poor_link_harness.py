"""The poor-link harness itself: each mechanism carries bytes intact, at about its nominal rate, and cuts.

Transfers run between two small scripts (a server and a client, see SERVER and CLIENT) so that the same code
runs inside the namespaces and on loopback through the proxy. Rates are measured where the bytes arrive.
"""

from __future__ import annotations

import hashlib
import json
import random
import subprocess
import sys
import time
from collections.abc import Iterator

import pytest

from harness.poor_link import NS_PREFIX, NetnsError, NetnsLink, ThrottlingProxy

RATE_KBIT = 256
UP_BYTES = 96 * 1024  # ~3 s at 256 kbit/s
DOWN_BYTES = 48 * 1024
SERVER_PORT = 5001  # inside the center namespace, which nothing else uses

# Protocol: the client sends b"U" or b"D" and an 8-digit byte count. "U": it then uploads that many bytes
# and half-closes; the server answers with a JSON line describing what arrived. "D": the server sends that
# many bytes and closes. Payloads are random.Random(count).randbytes(count) on both sides.
_COMMON = r"""
import hashlib, json, random, socket, sys, time

def payload(n):
    return random.Random(n).randbytes(n)

def receive(sock):
    # Returns bytes, sha256 and the rate after the first chunk (which a token bucket lets through at once).
    digest, total, first, start, end = hashlib.sha256(), 0, 0, None, None
    while chunk := sock.recv(65536):
        if start is None:
            start, first = time.monotonic(), len(chunk)
        digest.update(chunk)
        total += len(chunk)
        end = time.monotonic()
    rate = (total - first) * 8 / 1000 / (end - start) if end and end > start else None
    return {"bytes": total, "sha256": digest.hexdigest(), "rate_kbit": rate}
"""

SERVER = (
    _COMMON
    + r"""
listener = socket.create_server((sys.argv[1], int(sys.argv[2])))
print("ready", listener.getsockname()[1], flush=True)
while True:
    conn, _ = listener.accept()
    with conn:
        try:
            mode, count = conn.recv(1, socket.MSG_WAITALL), int(conn.recv(8, socket.MSG_WAITALL))
            if mode == b"U":
                conn.sendall(json.dumps(receive(conn)).encode() + b"\n")
            else:
                conn.sendall(payload(count))
        except (OSError, ValueError):
            pass
"""
)

CLIENT = (
    _COMMON
    + r"""
host, port, mode, count, timeout = sys.argv[1], int(sys.argv[2]), sys.argv[3], int(sys.argv[4]), float(sys.argv[5])
try:
    with socket.create_connection((host, port), timeout=timeout) as sock:
        sock.sendall(mode.encode() + b"%08d" % count)
        if mode == "U":
            sock.sendall(payload(count))
            sock.shutdown(socket.SHUT_WR)
            result = json.loads(sock.makefile().readline())
        else:
            result = receive(sock)
    result["ok"] = result["bytes"] == count
except (OSError, ValueError) as exc:
    result = {"ok": False, "error": repr(exc)}
print(json.dumps(result), flush=True)
"""
)


def expected_sha256(count: int) -> str:
    return hashlib.sha256(random.Random(count).randbytes(count)).hexdigest()


def wait_ready(server: subprocess.Popen[str]) -> int:
    assert server.stdout is not None
    word, port = server.stdout.readline().split()
    assert word == "ready"
    return int(port)


def finish(client: subprocess.Popen[str], timeout: float = 30) -> dict:
    out, _ = client.communicate(timeout=timeout)
    return json.loads(out)


def assert_intact_at_rate(result: dict, count: int) -> None:
    assert result["ok"], result
    assert result["sha256"] == expected_sha256(count)
    ratio = result["rate_kbit"] / RATE_KBIT
    assert 0.6 <= ratio <= 1.15, f"{result['rate_kbit']:.1f} kbit/s is {ratio:.2f}x the nominal {RATE_KBIT}"


# --- network namespaces ------------------------------------------------------------------------------


@pytest.fixture
def link() -> Iterator[NetnsLink]:
    ok, reason = NetnsLink.available()
    if not ok:
        pytest.skip(reason)
    with NetnsLink(rate_kbit=RATE_KBIT) as link:
        yield link


def netns_server(link: NetnsLink) -> None:
    argv = [sys.executable, "-c", SERVER, link.center_ip, str(SERVER_PORT)]
    server = link.popen("center", argv, stdout=subprocess.PIPE, text=True)
    wait_ready(server)
    server.stdout.close()  # it prints nothing more


def netns_client(link: NetnsLink, mode: str, count: int, timeout: float = 10) -> subprocess.Popen[str]:
    argv = [sys.executable, "-c", CLIENT, link.center_ip, str(SERVER_PORT), mode, str(count), str(timeout)]
    return link.popen("clinic", argv, stdout=subprocess.PIPE, text=True)


def our_namespaces() -> set[str]:
    out = subprocess.run(["ip", "netns", "list"], capture_output=True, text=True, check=True).stdout
    return {line.split()[0] for line in out.splitlines() if line.startswith(NS_PREFIX)}


@pytest.mark.parametrize(
    ("mode", "count"), [("U", UP_BYTES), ("D", DOWN_BYTES)], ids=["clinic-to-center", "center-to-clinic"]
)
def test_netns_carries_bytes_intact_at_the_nominal_rate(link: NetnsLink, mode: str, count: int) -> None:
    assert link.shaped()
    netns_server(link)
    assert_intact_at_rate(finish(netns_client(link, mode, count)), count)


def test_netns_down_refuses_and_up_restores(link: NetnsLink) -> None:
    netns_server(link)
    link.down()
    assert not finish(netns_client(link, "U", 1024, timeout=2))["ok"]
    link.up()
    assert link.shaped(), "tbf must survive the link going down and up"
    result = finish(netns_client(link, "U", 8192))
    assert result["ok"] and result["sha256"] == expected_sha256(8192)


def test_netns_transfer_stalls_through_a_short_cut_and_completes(link: NetnsLink) -> None:
    # Through a short cut TCP keeps the connection and retransmits once the link is back: the transfer
    # takes longer by at least the cut, but arrives intact.
    count, cut_s = 64 * 1024, 1.5
    netns_server(link)
    started = time.monotonic()
    client = netns_client(link, "U", count, timeout=20)
    time.sleep(0.5)
    link.flap(cut_s)
    result = finish(client)
    nominal_s = count * 8 / 1000 / RATE_KBIT
    assert result["ok"] and result["sha256"] == expected_sha256(count)
    assert time.monotonic() - started > nominal_s + cut_s * 0.8


def test_netns_exit_leaves_no_namespace_even_after_a_failed_setup() -> None:
    ok, reason = NetnsLink.available()
    if not ok:
        pytest.skip(reason)
    with NetnsLink() as link:
        link.popen("center", ["sleep", "60"])
        names = {link.center_ns, link.clinic_ns}
        assert names <= our_namespaces()
    assert not names & our_namespaces()

    broken = NetnsLink(rate_kbit=0)  # tc rejects it, after the namespaces and veth exist
    with pytest.raises(NetnsError), broken:
        pass
    assert not {broken.center_ns, broken.clinic_ns} & our_namespaces()


# --- loopback proxy ----------------------------------------------------------------------------------


@pytest.fixture
def loopback_server() -> Iterator[int]:
    server = subprocess.Popen([sys.executable, "-c", SERVER, "127.0.0.1", "0"], stdout=subprocess.PIPE, text=True)
    try:
        yield wait_ready(server)
    finally:
        server.kill()
        server.communicate()


@pytest.fixture
def proxy(loopback_server: int) -> Iterator[ThrottlingProxy]:
    with ThrottlingProxy("127.0.0.1", loopback_server, rate_kbit=RATE_KBIT) as proxy:
        yield proxy


def proxy_client(proxy: ThrottlingProxy, mode: str, count: int, timeout: float = 10) -> subprocess.Popen[str]:
    argv = [sys.executable, "-c", CLIENT, "127.0.0.1", str(proxy.port), mode, str(count), str(timeout)]
    return subprocess.Popen(argv, stdout=subprocess.PIPE, text=True)


@pytest.mark.parametrize(("mode", "count"), [("U", UP_BYTES), ("D", DOWN_BYTES)], ids=["upstream", "downstream"])
def test_proxy_carries_bytes_intact_at_the_nominal_rate(proxy: ThrottlingProxy, mode: str, count: int) -> None:
    assert_intact_at_rate(finish(proxy_client(proxy, mode, count)), count)


def test_proxy_down_cuts_live_and_new_connections_and_up_restores(proxy: ThrottlingProxy) -> None:
    live = proxy_client(proxy, "U", UP_BYTES)
    time.sleep(0.5)
    proxy.down()
    assert not finish(live, timeout=5)["ok"]
    assert not finish(proxy_client(proxy, "U", 1024, timeout=2))["ok"]
    proxy.up()
    result = finish(proxy_client(proxy, "U", 8192))
    assert result["ok"] and result["sha256"] == expected_sha256(8192)
