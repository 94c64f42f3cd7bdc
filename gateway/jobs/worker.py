"""A worker process: claims analysis jobs one at a time and runs each in a child process it can kill.

The worker renews the job's lease while the child runs, and kills the child when the job is cancelled or the
lease was lost. It runs niced, so the API answers first. Started by the gateway (`burnedge serve`), it exits
when the gateway is gone; started on its own (`burnedge worker`), it runs until stopped. SIGTERM hands the
running job back to the queue at once, to be resumed from its last finished stage.
"""

from __future__ import annotations

import faulthandler
import logging
import multiprocessing
import os
import signal
import socket
import threading
import time
import uuid
from collections.abc import Sequence
from pathlib import Path

from gateway.jobs import folders
from gateway.jobs.events import Reaction
from gateway.jobs.queue import Claim, JobQueue
from gateway.storage.database import Database
from schemas.config import Config
from schemas.errors import StorageError
from schemas.jobs import AttemptOutcome, JobState

log = logging.getLogger("burnedge.worker")


def exit_name(code: int | None) -> str:
    """'SIGSEGV', 'exit code 1', ... for a process's exit code."""
    if code is None:
        return "still running"
    if code < 0:
        try:
            return signal.Signals(-code).name
        except ValueError:
            return f"signal {-code}"
    return f"exit code {code}"


def describe_exit(code: int | None) -> str:
    """Completes 'try 1 ...': 'ended by SIGSEGV', 'ended with exit code 1'."""
    name = exit_name(code)
    return f"ended by {name}" if code is not None and code < 0 else f"ended with {name}"


class Worker:
    def __init__(self, config: Config, *, supervised: bool = False, reactions: Sequence[Reaction] = ()):
        self.config = config
        self.reactions = tuple(reactions)
        """What the jobs' processes publish a stored analysis to (gateway/jobs/events.py)."""
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
            try:
                claim = self.queue.claim(self.owner)
            except StorageError as exc:  # database busy: look again later, never die of it
                log.warning("worker %s: cannot look for work now (%s)", self.owner, exc.detail)
                self.stopping.wait(self.config.jobs.poll_s)
                continue
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
        output = TryLog(folders.job_dir(self.config, claim.job_id) / "logs" / f"try-{claim.attempt}.log")
        child = self.context.Process(
            target=_run_child,
            args=(self.config, claim, str(output.path), self.reactions),
            name=f"analysis-{claim.job_id}",
        )
        child.start()
        try:
            return self._watch(claim, child, output)
        finally:
            output.forward()

    def _watch(self, claim: Claim, child, output: TryLog) -> JobState:
        conf = self.config.jobs
        started = next_beat = time.monotonic()
        finished = False
        while child.is_alive():
            child.join(timeout=min(0.5, conf.heartbeat_s))
            output.forward()
            if self.stopping.is_set() or self.orphaned():
                _kill(child)
                return _quietly(lambda: self.queue.release(claim), JobState.queued)
            if time.monotonic() - started > conf.max_run_s and child.is_alive():
                _kill(child)
                log.error("analysis %s: still running after %.0f s, stopped as hung", claim.job_id, conf.max_run_s)
                return self._ended(
                    claim,
                    f"was still running after {conf.max_run_s:.0f} s and was stopped as hung",
                    AttemptOutcome.hung,
                    "SIGKILL",
                    output,
                )
            if time.monotonic() < next_beat or not child.is_alive() or finished:
                continue
            try:
                beat = self.queue.heartbeat(claim)
            except StorageError as exc:  # the lease outlasts a few missed beats
                log.warning("analysis %s: heartbeat missed (%s)", claim.job_id, exc.detail)
                continue
            next_beat = time.monotonic() + conf.heartbeat_s
            finished = beat.finished  # the result is stored: the process only updates the healing track now
            if not beat.owned and not finished:
                log.warning("analysis %s: lease lost; stopping this try", claim.job_id)
                _kill(child)
                return JobState.running
            if beat.cancel:
                _kill(child)
                _quietly(lambda: self.queue.finish(claim, JobState.cancelled, error=None, message="cancelled"), None)
                log.info("analysis %s cancelled", claim.job_id)
                return JobState.cancelled
        if child.exitcode != 0:
            return self._ended(
                claim, describe_exit(child.exitcode), AttemptOutcome.crashed, exit_name(child.exitcode), output
            )
        return JobState.done

    def _ended(self, claim: Claim, reason: str, outcome: AttemptOutcome, exit: str, output: TryLog) -> JobState:
        """A try that did not finish: recorded with the end of its log, then retried or failed."""
        output.forward()
        tail = output.tail()
        state = _quietly(
            lambda: self.queue.retry_or_fail(claim, reason, outcome=outcome, exit=exit, log_tail=tail), JobState.running
        )
        said = _quietly(lambda: self.queue.get(claim.job_id), None)
        lines = "\n    ".join(tail.strip().splitlines()[-12:])
        log.error(
            "analysis %s: %s (%s); its process last wrote:\n    %s",
            claim.job_id,
            said.error if said and said.error else f"try {claim.attempt} {reason}",
            state.value,
            lines,
        )
        return state


def _quietly(action, fallback):
    """A queue write that must not kill the worker: if the database stays busy the lease runs out and the gateway
    queues the job again."""
    try:
        return action()
    except StorageError as exc:
        log.warning("queue not updated (%s); the job's lease will run out and it will be queued again", exc.detail)
        return fallback


def _run_child(config: Config, claim: Claim, log_path: str, reactions: Sequence[Reaction]) -> None:
    _redirect_output(log_path)
    # Imported here, in the job's own process: the analysis libraries (pycolmap, Open3D, onnxruntime) are never
    # loaded into the gateway or the worker, which stay small and cannot be crashed by them.
    from gateway.jobs import runner

    # After the imports: COLMAP's glog installs a crash handler of its own (the native stack); faulthandler prints
    # the Python stack that led into the crash, then hands the signal on to it.
    faulthandler.enable()
    runner.child_main(config, claim, reactions)


class TryLog:
    """One try's output file (the child's stdout and stderr), followed into the worker's own log as it grows."""

    TAIL_BYTES = 16384

    def __init__(self, path: Path):
        self.path = path
        path.parent.mkdir(parents=True, exist_ok=True)
        self.offset = path.stat().st_size if path.exists() else 0
        self.start = self.offset

    def forward(self) -> None:
        try:
            with open(self.path, "rb") as handle:
                handle.seek(self.offset)
                chunk = handle.read()
        except FileNotFoundError:
            return
        if chunk:
            self.offset += len(chunk)
            os.write(2, chunk)

    def tail(self) -> str:
        """The end of what this try wrote (a try repeated after a hand-back appends to the same file)."""
        try:
            with open(self.path, "rb") as handle:
                handle.seek(max(self.start, self.offset - self.TAIL_BYTES))
                return handle.read(self.TAIL_BYTES).decode("utf-8", "replace")
        except FileNotFoundError:
            return ""


def _redirect_output(path: str) -> None:
    """Point this process's stdout and stderr (the file descriptors: native libraries write there too, and the
    analysis processes inherit them) at the log file."""
    import sys

    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o640)
    sys.stdout.flush()
    sys.stderr.flush()
    os.dup2(fd, 1)
    os.dup2(fd, 2)
    os.close(fd)


def _kill(child) -> None:
    child.kill()
    child.join(timeout=10)


def main(config: Config, supervised: bool = False, drain: bool = False, reactions: Sequence[Reaction] = ()) -> int:
    """Process entry point: lower priority, stop cleanly on SIGTERM."""
    if config.jobs.log_file:
        _redirect_output(config.jobs.log_file)
    if supervised:
        logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    os.nice(config.jobs.nice)
    worker = Worker(config, supervised=supervised, reactions=reactions)
    signal.signal(signal.SIGTERM, lambda *_: worker.stopping.set())
    # Ctrl-C in the gateway's terminal reaches its workers too: the gateway stops them itself (SIGTERM); a worker on
    # its own treats Ctrl-C like SIGTERM and hands its job back.
    signal.signal(signal.SIGINT, signal.SIG_IGN if supervised else (lambda *_: worker.stopping.set()))
    return worker.serve(drain=drain)
