"""A slow, breakable network link between two processes, for testing sync over a poor connection.

Two mechanisms:

* ``NetnsLink``: two Linux network namespaces ("center" and "clinic") joined by a veth pair, each end
  shaped with a ``tbf`` qdisc, so both directions run at ``rate_kbit``. Real kernel TCP, real packets,
  real link-down. Needs root, ``ip`` and ``tc``.
* ``ThrottlingProxy``: the fallback where namespaces are unavailable: a loopback TCP proxy that limits
  each direction with a token bucket, and cuts every connection on ``down()``.
"""

from __future__ import annotations

import asyncio
import functools
import itertools
import json
import logging
import os
import shutil
import signal
import socket
import struct
import subprocess
import threading
import time
from collections.abc import Sequence
from typing import Any, Literal

logger = logging.getLogger(__name__)

Side = Literal["center", "clinic"]

# Namespaces are named PREFIX<pid>-<counter>-<side>, so two runs never collide and the ones a killed run
# left behind can be recognised (their pid is gone) and removed.
NS_PREFIX = "burnedge-pl-"
_instance_counter = itertools.count()

# tbf parameters, chosen by measuring a 160 KiB bulk TCP transfer over the veth pair at 256 kbit/s while a
# second connection echoed 64-byte messages through the same queue (the "small packets" case):
#   burst 3028 B = two full 1514 B frames. tbf drops any packet longer than its bucket, so it must hold at
#     least one full frame; with only one (1600 B) and a short queue, bulk TCP fell to 0.77x. Kept small
#     so a short transfer is not flattered by the initial burst (8000 B gave 1.00x on 160 KiB).
#   latency 200 ms, i.e. a queue of 200 ms x 32 kB/s + burst ~ 9.4 kB (six full frames): bulk TCP gets
#     0.96x of the nominal rate, which is the ceiling (tbf counts whole frames: 1448 payload bytes in a
#     1514-byte frame), and the small messages waited ~240 ms (max 290 ms) behind it, never dropped.
#     With 100 ms the queue overflowed onto them (a drop costs a retransmit timeout: up to 0.5 s, at
#     50 ms 1.8 s); with 300 ms or more nothing improves but the queueing delay (bufferbloat).
DEFAULT_BURST_BYTES = 3028
DEFAULT_LATENCY_MS = 200

_COMMAND_TIMEOUT_S = 10


class NetnsError(RuntimeError):
    """A command setting up or changing the namespace link failed."""


def _run(*argv: str, check: bool = True) -> subprocess.CompletedProcess[str]:
    proc = subprocess.run(argv, capture_output=True, text=True, timeout=_COMMAND_TIMEOUT_S)
    if check and proc.returncode != 0:
        raise NetnsError(f"{' '.join(argv)} failed ({proc.returncode}): {proc.stderr.strip()}")
    return proc


def _list_namespaces() -> list[str]:
    # Lines look like "name" or "name (id: 3)".
    return [line.split()[0] for line in _run("ip", "netns", "list").stdout.splitlines() if line.strip()]


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _kill_namespace_processes(ns: str, grace_s: float = 2.0) -> None:
    """SIGTERM, then SIGKILL, every process still running inside ``ns``."""
    deadline = time.monotonic() + grace_s
    sig = signal.SIGTERM
    while True:
        pids = [int(p) for p in _run("ip", "netns", "pids", ns, check=False).stdout.split()]
        if not pids:
            return
        if time.monotonic() > deadline:
            sig = signal.SIGKILL
        for pid in pids:
            try:
                os.kill(pid, sig)
            except ProcessLookupError:
                pass
        if sig == signal.SIGKILL and time.monotonic() > deadline + grace_s:
            logger.warning("processes %s in namespace %s survive SIGKILL", pids, ns)
            return
        time.sleep(0.05)


def _delete_namespace(ns: str) -> None:
    _kill_namespace_processes(ns)
    # Deleting the namespace also destroys its veth end, and with it the peer.
    _run("ip", "netns", "del", ns, check=False)


def remove_stale_namespaces() -> list[str]:
    """Delete the namespaces of runs whose process is gone (killed before its ``__exit__``)."""
    removed = []
    for ns in _list_namespaces():
        if not ns.startswith(NS_PREFIX):
            continue
        pid_text = ns[len(NS_PREFIX) :].split("-", 1)[0]
        if pid_text.isdigit() and not _pid_alive(int(pid_text)):
            _delete_namespace(ns)
            removed.append(ns)
    if removed:
        logger.info("removed stale namespaces %s", removed)
    return removed


class NetnsLink:
    """Two network namespaces joined by a veth pair shaped to ``rate_kbit`` in both directions.

    >>> with NetnsLink() as link:
    ...     server = link.popen("center", ["python", "-m", "http.server", "--bind", link.center_ip])
    ...     link.flap(2.0)
    """

    _VETH = {"center": "veth-center", "clinic": "veth-clinic"}

    def __init__(
        self,
        rate_kbit: int = 256,
        *,
        burst_bytes: int = DEFAULT_BURST_BYTES,
        latency_ms: int = DEFAULT_LATENCY_MS,
    ) -> None:
        self.rate_kbit = rate_kbit
        self.burst_bytes = burst_bytes
        self.latency_ms = latency_ms
        pid, n = os.getpid(), next(_instance_counter)
        self.center_ns = f"{NS_PREFIX}{pid}-{n}-center"
        self.clinic_ns = f"{NS_PREFIX}{pid}-{n}-clinic"
        # Each namespace has its own addresses, so equal subnets could not clash; distinct ones only make
        # captures and logs of concurrent runs easier to tell apart.
        k = (pid * 16 + n) % (254 * 254)
        subnet = f"10.{k // 254 + 1}.{k % 254 + 1}"
        self.center_ip = f"{subnet}.1"
        self.clinic_ip = f"{subnet}.2"
        self._procs: list[subprocess.Popen[Any]] = []

    # --- lifecycle -------------------------------------------------------------------------------

    def __enter__(self) -> NetnsLink:
        remove_stale_namespaces()
        try:
            self._setup()
        except BaseException:
            try:
                self._teardown()
            except Exception:
                logger.exception("cleaning up after a failed setup failed too")
            raise
        return self

    def __exit__(self, *exc_info: object) -> None:
        self._teardown()

    def _setup(self) -> None:
        for side in ("center", "clinic"):
            _run("ip", "netns", "add", self._ns(side))
        # Created directly inside the namespaces: the veth names never exist in the host namespace.
        _run(
            "ip",
            "link",
            "add",
            self._VETH["center"],
            "netns",
            self.center_ns,
            "type",
            "veth",
            "peer",
            "name",
            self._VETH["clinic"],
            "netns",
            self.clinic_ns,
        )
        for side, ip in (("center", self.center_ip), ("clinic", self.clinic_ip)):
            ns, dev = self._ns(side), self._VETH[side]
            # No IPv6: its link-up chatter (DAD, router and MLD solicitations) would share the slow link.
            _run("ip", "netns", "exec", ns, "sysctl", "-qw", "net.ipv6.conf.all.disable_ipv6=1")
            _run("ip", "-n", ns, "addr", "add", f"{ip}/24", "dev", dev)
            _run("ip", "-n", ns, "link", "set", "lo", "up")
            _run("ip", "-n", ns, "link", "set", dev, "up")
            self._shape(side)
        logger.info(
            "netns link %s <-> %s at %d kbit/s (%s <-> %s)",
            self.center_ns,
            self.clinic_ns,
            self.rate_kbit,
            self.center_ip,
            self.clinic_ip,
        )

    def _teardown(self) -> None:
        for proc in self._procs:
            if proc.poll() is None:
                proc.kill()
            try:
                proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                logger.warning("process %d did not exit after SIGKILL", proc.pid)
        self._procs.clear()
        existing = set(_list_namespaces())
        for ns in (self.center_ns, self.clinic_ns):
            if ns in existing:
                _delete_namespace(ns)

    # --- shaping ---------------------------------------------------------------------------------

    def _ns(self, side: Side | str) -> str:
        if side == "center":
            return self.center_ns
        if side == "clinic":
            return self.clinic_ns
        raise ValueError(f"side must be 'center' or 'clinic', not {side!r}")

    def _shape(self, side: Side) -> None:
        _run(
            "tc",
            "-n",
            self._ns(side),
            "qdisc",
            "replace",
            "dev",
            self._VETH[side],
            "root",
            "tbf",
            "rate",
            f"{self.rate_kbit}kbit",
            "burst",
            str(self.burst_bytes),
            "latency",
            f"{self.latency_ms}ms",
        )

    def _side_shaped(self, side: Side) -> bool:
        out = _run("tc", "-j", "-n", self._ns(side), "qdisc", "show", "dev", self._VETH[side]).stdout
        rate_bytes = self.rate_kbit * 1000 // 8
        return any(q.get("kind") == "tbf" and q.get("options", {}).get("rate") == rate_bytes for q in json.loads(out))

    def shaped(self) -> bool:
        """Whether both veth ends still carry the tbf qdisc at ``rate_kbit``."""
        return self._side_shaped("center") and self._side_shaped("clinic")

    # --- use -------------------------------------------------------------------------------------

    def popen(self, side: Side, argv: Sequence[str], **popen_kwargs: Any) -> subprocess.Popen[Any]:
        """Start ``argv`` inside the side's namespace. It is killed, if still running, on exit."""
        proc = subprocess.Popen(["ip", "netns", "exec", self._ns(side), *argv], **popen_kwargs)
        self._procs.append(proc)
        return proc

    def down(self) -> None:
        """Cut the link: both veth ends down, so packets are neither sent nor received."""
        for side in ("center", "clinic"):
            _run("ip", "-n", self._ns(side), "link", "set", self._VETH[side], "down")
        logger.info("netns link %s down", self.center_ns)

    def up(self) -> None:
        """Restore the link, and the shaping if it did not survive (it does on the kernels tried)."""
        for side in ("center", "clinic"):
            _run("ip", "-n", self._ns(side), "link", "set", self._VETH[side], "up")
            if not self._side_shaped(side):
                logger.warning("tbf qdisc on %s lost across down/up; adding it again", self._VETH[side])
                self._shape(side)
        logger.info("netns link %s up", self.center_ns)

    def flap(self, down_s: float) -> None:
        """Cut the link for ``down_s`` seconds, then restore it (blocks meanwhile)."""
        self.down()
        time.sleep(down_s)
        self.up()

    # --- probing ---------------------------------------------------------------------------------

    @staticmethod
    def available() -> tuple[bool, str]:
        """Whether namespaces, veth and tbf work here, and if not, why (for ``pytest.skip``)."""
        return _probe_netns()


@functools.cache
def _probe_netns() -> tuple[bool, str]:
    if os.geteuid() != 0:
        return False, "network namespaces need root"
    missing = [tool for tool in ("ip", "tc") if shutil.which(tool) is None]
    if missing:
        return False, f"missing {' and '.join(missing)} (iproute2)"
    try:
        with NetnsLink() as link:
            if not link.shaped():
                return False, "tbf qdisc did not take effect"
    except (NetnsError, OSError, subprocess.TimeoutExpired) as exc:
        return False, f"cannot set up namespaces+veth+tbf: {exc}"
    return True, "namespaces, veth and tbf work"


# ================================================================================================
# Fallback: loopback proxy with token buckets
# ================================================================================================


class _TokenBucket:
    """Paces bytes to ``rate`` bytes/s with bursts up to ``burst`` bytes; shared by all connections.

    A taker reserves its bytes at once (possibly into debt) and sleeps until that debt is paid, so
    concurrent takers queue up in arrival order and the total never exceeds the rate.
    """

    def __init__(self, rate: float, burst: int) -> None:
        self.rate = rate
        self.burst = burst
        self.reset()

    def reset(self) -> None:
        self._tokens = float(self.burst)
        self._stamp = time.monotonic()

    async def take(self, n: int) -> None:
        now = time.monotonic()
        self._tokens = min(self.burst, self._tokens + (now - self._stamp) * self.rate) - n
        self._stamp = now
        if self._tokens < 0:
            await asyncio.sleep(-self._tokens / self.rate)


def _abort(writer: asyncio.StreamWriter) -> None:
    """Close at once with a RST: unsent data is dropped, the peer sees 'connection reset'."""
    sock = writer.get_extra_info("socket")
    if sock is not None:
        try:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
        except OSError:
            pass
    writer.transport.abort()


class ThrottlingProxy:
    """Loopback TCP proxy 127.0.0.1:``port`` -> ``target_host``:``target_port`` (IPv4), ``rate_kbit`` each way.

    The rate is shared by all connections, like a link's. ``down()`` resets every live connection, and new
    ones are accepted and reset at once until ``up()`` (a refused connect would need the port to be given
    up, and another process could take it meanwhile). Runs an asyncio
    loop in a background thread; use as a context manager or call ``start()``/``stop()``.
    """

    # Packet-sized reads keep the pacing smooth and let connections interleave.
    CHUNK = 1460
    BURST_BYTES = 3028
    # Small socket buffers on the proxy's sockets: at 256 kbit/s the kernel's defaults (or autotuning)
    # would hold many seconds of data "sent" by one end but not yet through the link.
    SOCKET_BUFFER = 16384

    def __init__(self, target_host: str, target_port: int, rate_kbit: int = 256) -> None:
        self.target = (target_host, target_port)
        self.rate_kbit = rate_kbit
        rate = rate_kbit * 1000 / 8
        self._buckets = {"up": _TokenBucket(rate, self.BURST_BYTES), "down": _TokenBucket(rate, self.BURST_BYTES)}
        self._listener = self._make_listener()
        self.port: int = self._listener.getsockname()[1]
        self._loop = asyncio.new_event_loop()
        self._thread: threading.Thread | None = None
        self._server: asyncio.Server | None = None
        self._writers: set[asyncio.StreamWriter] = set()
        self._is_down = False

    def _make_listener(self) -> socket.socket:
        sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        # Accepted sockets inherit the buffer size (it must be set before the handshake to shape the window).
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, self.SOCKET_BUFFER)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, self.SOCKET_BUFFER)
        sock.bind(("127.0.0.1", 0))
        sock.listen(64)
        sock.setblocking(False)
        return sock

    # --- lifecycle -------------------------------------------------------------------------------

    def __enter__(self) -> ThrottlingProxy:
        self.start()
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.stop()

    def start(self) -> None:
        self._thread = threading.Thread(
            target=self._loop.run_forever, name=f"throttling-proxy-{self.port}", daemon=True
        )
        self._thread.start()
        self._call(self._start_server())
        logger.info("proxy 127.0.0.1:%d -> %s:%d at %d kbit/s", self.port, *self.target, self.rate_kbit)

    def stop(self) -> None:
        if self._thread is None:
            self._listener.close()
            self._loop.close()
            return
        self._call(self._stop_server())
        self._loop.call_soon_threadsafe(self._loop.stop)
        self._thread.join(timeout=5)
        self._thread = None
        self._loop.close()

    def _call(self, coro: Any) -> Any:
        return asyncio.run_coroutine_threadsafe(coro, self._loop).result(timeout=10)

    async def _start_server(self) -> None:
        self._server = await asyncio.start_server(self._handle, sock=self._listener)

    async def _stop_server(self) -> None:
        assert self._server is not None
        self._server.close()
        self._abort_all()
        tasks = [t for t in asyncio.all_tasks() if t is not asyncio.current_task()]
        for task in tasks:
            task.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)
        await self._server.wait_closed()

    # --- link state ------------------------------------------------------------------------------

    def down(self) -> None:
        """Reset every live connection; new ones are reset at once until ``up()``."""
        self._call(self._set_down(True))
        logger.info("proxy %d down", self.port)

    def up(self) -> None:
        """Accept and forward connections again (the ones cut by ``down()`` stay cut)."""
        self._call(self._set_down(False))
        logger.info("proxy %d up", self.port)

    def flap(self, down_s: float) -> None:
        """Cut for ``down_s`` seconds, then restore (blocks meanwhile)."""
        self.down()
        time.sleep(down_s)
        self.up()

    async def _set_down(self, is_down: bool) -> None:
        self._is_down = is_down
        if is_down:
            self._abort_all()
        else:
            for bucket in self._buckets.values():
                bucket.reset()

    def _abort_all(self) -> None:
        for writer in list(self._writers):
            _abort(writer)
        self._writers.clear()

    # --- forwarding ------------------------------------------------------------------------------

    async def _handle(self, client_reader: asyncio.StreamReader, client_writer: asyncio.StreamWriter) -> None:
        if self._is_down:
            _abort(client_writer)
            return
        try:
            upstream_reader, upstream_writer = await self._connect_upstream()
        except OSError as exc:
            logger.info("proxy %d: upstream %s:%d unreachable: %s", self.port, *self.target, exc)
            _abort(client_writer)
            return
        pair = (client_writer, upstream_writer)
        if self._is_down:  # went down while connecting
            for writer in pair:
                _abort(writer)
            return
        self._writers.update(pair)
        for writer in pair:
            writer.transport.set_write_buffer_limits(high=self.SOCKET_BUFFER)
        try:
            await asyncio.gather(
                self._pump(client_reader, upstream_writer, self._buckets["up"], pair),
                self._pump(upstream_reader, client_writer, self._buckets["down"], pair),
            )
        finally:
            for writer in pair:
                self._writers.discard(writer)
                writer.close()

    async def _connect_upstream(self) -> tuple[asyncio.StreamReader, asyncio.StreamWriter]:
        sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, self.SOCKET_BUFFER)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, self.SOCKET_BUFFER)
        sock.setblocking(False)
        try:
            await asyncio.wait_for(self._loop.sock_connect(sock, self.target), timeout=10)
        except BaseException:
            sock.close()
            raise
        return await asyncio.open_connection(sock=sock)

    async def _pump(
        self,
        reader: asyncio.StreamReader,
        writer: asyncio.StreamWriter,
        bucket: _TokenBucket,
        pair: tuple[asyncio.StreamWriter, asyncio.StreamWriter],
    ) -> None:
        try:
            while data := await reader.read(self.CHUNK):
                await bucket.take(len(data))
                if writer.is_closing():
                    return
                writer.write(data)
                await writer.drain()
            if not writer.is_closing() and writer.can_write_eof():
                writer.write_eof()  # pass the half-close on
        except OSError:
            # One end went away: like a broken link, the other end is cut too.
            for w in pair:
                _abort(w)
