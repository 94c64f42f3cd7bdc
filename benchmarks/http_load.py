"""A small keep-alive HTTP/1.1 load generator on raw asyncio sockets.

A general client (httpx) spends more CPU per request than the server under test on
this 2-core box, which would cap both sides at the client's speed and hide the
difference we want to see. Requests and response parsing here are minimal.
"""

from __future__ import annotations

import asyncio
import statistics
import time
from collections.abc import Callable
from dataclasses import dataclass


@dataclass
class LoadResult:
    requests: int
    errors: int
    seconds: float
    latencies_ms: list[float]

    @property
    def rps(self) -> float:
        return self.requests / self.seconds

    def percentile(self, q: float) -> float:
        data = sorted(self.latencies_ms)
        return data[min(len(data) - 1, int(q / 100 * len(data)))] if data else float("nan")

    def row(self) -> dict:
        return {
            "requests": self.requests,
            "errors": self.errors,
            "rps": round(self.rps, 1),
            "p50_ms": round(self.percentile(50), 2),
            "p99_ms": round(self.percentile(99), 2),
            "mean_ms": round(statistics.fmean(self.latencies_ms), 2) if self.latencies_ms else None,
        }


RequestFactory = Callable[[int, dict], bytes]
"""(worker index, worker state) -> raw request bytes."""


async def _read_response(reader: asyncio.StreamReader) -> tuple[int, dict[str, str], bytes]:
    head = await reader.readuntil(b"\r\n\r\n")
    lines = head.decode("latin-1").split("\r\n")
    status = int(lines[0].split(" ", 2)[1])
    headers = {}
    for line in lines[1:]:
        if ":" in line:
            k, v = line.split(":", 1)
            headers[k.strip().lower()] = v.strip()
    body = await reader.readexactly(int(headers.get("content-length", "0")))
    return status, headers, body


async def _worker(
    i: int, host: str, port: int, make: RequestFactory, on_response, stop_at: float, warm_until: float, out: LoadResult
) -> None:
    reader, writer = await asyncio.open_connection(host, port)
    state: dict = {}
    try:
        while (now := time.perf_counter()) < stop_at:
            t0 = now
            writer.write(make(i, state))
            status, headers, body = await _read_response(reader)
            t1 = time.perf_counter()
            ok = on_response(i, state, status, headers, body)
            if t0 >= warm_until:
                out.requests += 1
                out.errors += 0 if ok else 1
                out.latencies_ms.append((t1 - t0) * 1000)
    finally:
        writer.close()


async def _run(host, port, make, on_response, connections, seconds, warmup) -> LoadResult:
    start = time.perf_counter()
    out = LoadResult(0, 0, seconds, [])
    await asyncio.gather(
        *(
            _worker(i, host, port, make, on_response, start + warmup + seconds, start + warmup, out)
            for i in range(connections)
        )
    )
    return out


def run_load(
    port: int,
    make: RequestFactory,
    on_response=None,
    *,
    connections: int = 16,
    seconds: float = 8.0,
    warmup: float = 2.0,
    host: str = "127.0.0.1",
) -> LoadResult:
    def default_check(i, state, status, headers, body) -> bool:
        return 200 <= status < 300

    return asyncio.run(_run(host, port, make, on_response or default_check, connections, seconds, warmup))


def request(method: str, path: str, headers: dict[str, str] | None = None, body: bytes = b"") -> bytes:
    lines = [f"{method} {path} HTTP/1.1", "Host: 127.0.0.1", f"Content-Length: {len(body)}"]
    lines += [f"{k}: {v}" for k, v in (headers or {}).items()]
    return ("\r\n".join(lines) + "\r\n\r\n").encode("latin-1") + body
