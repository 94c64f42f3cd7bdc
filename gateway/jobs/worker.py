"""A worker process: claims analysis jobs one at a time and runs each in a child process it can kill.

The worker renews the job's lease while the child runs, and kills the child when the job is cancelled or the
lease was lost. It runs niced, so the API answers first. Started by the gateway (`burnedge serve`), it exits
when the gateway is gone; started on its own (`burnedge worker`), it runs until stopped. SIGTERM hands the
running job back to the queue at once, to be resumed from its last finished stage.
"""

from __future__ import annotations

import logging
import multiprocessing
import os
import signal
import socket
import threading
import time
import uuid

from gateway.jobs.queue import Claim, JobQueue
from gateway.storage.database import Database
from schemas.config import Config
from schemas.jobs import JobState

log = logging.getLogger("burnedge.worker")


def describe_exit(code: int | None) -> str:
    if code is None:
        return "the analysis process did not end"
    if code < 0:
        try:
            return f"the analysis process was killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"the analysis process was killed by signal {-code}"
    return f"the analysis process ended with exit code {code}"


class Worker:
    def __init__(self, config: Config, *, supervised: bool = False):
        self.config = config
        self.db = Database.from_config(config.gateway)
        self.queue = JobQueue(self.db, config.jobs)
        self.owner = f"{socket.gethostname()}:{os.getpid()}:{uuid.uuid4().hex[:8]}"
        self.parent = os.getppid() if supervised else None
        self.stopping = threading.Event()
        self.context = multiprocessing.get_context("spawn")

    def orphaned(self) -> bool:
        return self.parent is not None and os.getppid() != self.parent

    def serve(self, *, drain: bool = False) -> int:
        """Run jobs until stopped (or, with `drain`, until none is ready to run); returns how many were run."""
        done = 0
        log.info("worker %s: waiting for analyses (nice %d)", self.owner, os.nice(0))
        while not self.stopping.is_set() and not self.orphaned():
            claim = self.queue.claim(self.owner)
            if claim is None:
                if drain:
                    break
                self.stopping.wait(self.config.jobs.poll_s)
                continue
            self.run(claim)
            done += 1
        self.db.close()
        return done

    def run(self, claim: Claim) -> JobState:
        log.info("worker %s: analysis %s, try %d", self.owner, claim.job_id, claim.attempt)
        child = self.context.Process(target=_run_child, args=(self.config, claim),
                                     name=f"analysis-{claim.job_id}")  # fmt: skip
        child.start()
        beat_every = self.config.jobs.heartbeat_s
        next_beat = time.monotonic() + beat_every
        finished = False
        while child.is_alive():
            child.join(timeout=min(0.5, beat_every))
            if self.stopping.is_set() or self.orphaned():
                _kill(child)
                if not self.orphaned():
                    self.queue.release(claim)
                return JobState.queued
            if time.monotonic() >= next_beat and child.is_alive() and not finished:
                beat = self.queue.heartbeat(claim)
                next_beat = time.monotonic() + beat_every
                finished = beat.finished  # stored: the process only updates the healing track now; let it
                if not beat.owned and not finished:
                    log.warning("analysis %s: lease lost to another worker; stopping this try", claim.job_id)
                    _kill(child)
                    return JobState.running
                if beat.cancel:
                    _kill(child)
                    self.queue.finish(claim, JobState.cancelled, error=None, message="cancelled")
                    log.info("analysis %s cancelled", claim.job_id)
                    return JobState.cancelled
        if child.exitcode != 0:
            return self.queue.retry_or_fail(claim, describe_exit(child.exitcode))
        return JobState.done


def _run_child(config: Config, claim: Claim) -> None:
    # Imported here, in the job's own process: the analysis libraries (pycolmap, Open3D, onnxruntime) are never
    # loaded into the gateway or the worker, which stay small and cannot be crashed by them.
    from gateway.jobs import runner

    runner.child_main(config, claim)


def _kill(child) -> None:
    child.kill()
    child.join(timeout=10)


def main(config: Config, supervised: bool = False, drain: bool = False) -> int:
    """Process entry point: lower priority, stop cleanly on SIGTERM."""
    if supervised:
        logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    os.nice(config.jobs.nice)
    worker = Worker(config, supervised=supervised)
    signal.signal(signal.SIGTERM, lambda *_: worker.stopping.set())
    return worker.serve(drain=drain)
