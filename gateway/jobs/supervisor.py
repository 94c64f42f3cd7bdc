"""The gateway's worker processes: started with it, restarted when one dies, stopped with it."""

from __future__ import annotations

import logging
import multiprocessing
from collections.abc import Sequence

from gateway.jobs import worker
from gateway.jobs.events import Reaction
from schemas.config import Config

log = logging.getLogger("burnedge.worker")


class Workers:
    def __init__(self, config: Config, reactions: Sequence[Reaction] = ()):
        self.config = config
        self.reactions = tuple(reactions)
        self.context = multiprocessing.get_context("spawn")
        self.processes: list[multiprocessing.process.BaseProcess] = []
        self.stopped = False

    def _spawn(self, index: int):
        process = self.context.Process(
            target=worker.main,
            args=(self.config, True, False, self.reactions),
            name=f"burnedge-worker-{index}",
            daemon=False,
        )
        process.start()
        log.info("analysis worker %d started (pid %d)", index, process.pid)
        return process

    def start(self) -> None:
        self.processes = [self._spawn(i) for i in range(self.config.jobs.workers)]

    def check(self) -> int:
        """Restart workers that died (killed, out of memory); returns how many were restarted."""
        restarted = 0
        for i, process in enumerate(self.processes if not self.stopped else []):
            if not process.is_alive():
                log.warning(
                    "analysis worker %d (pid %s) %s: restarting it",
                    i,
                    process.pid,
                    worker.describe_exit(process.exitcode),
                )
                process.join(timeout=0)
                self.processes[i] = self._spawn(i)
                restarted += 1
        return restarted

    @property
    def pids(self) -> list[int]:
        return [p.pid for p in self.processes if p.pid is not None]

    def stop(self, timeout_s: float = 10.0) -> None:
        """SIGTERM: each worker hands its job back to the queue and exits; killed if it does not in time."""
        self.stopped = True  # a check() running in the scheduler's thread must not start one again
        for process in self.processes:
            if process.is_alive():
                process.terminate()
        for process in self.processes:
            process.join(timeout=timeout_s)
            if process.is_alive():
                process.kill()
                process.join(timeout=5)
        self.processes = []
