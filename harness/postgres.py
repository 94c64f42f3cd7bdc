"""A real PostgreSQL server for tests, from Debian's packages: `initdb` in a temporary folder and `pg_ctl` on a
loopback port, with trust authentication for local connections only. One server per test session; each test gets
a database of its own. PostgreSQL refuses to run as root, so as root the server runs as the `postgres` account."""

from __future__ import annotations

import glob
import os
import pwd
import shutil
import subprocess
import tempfile
import uuid
from pathlib import Path

from harness.processes import free_port


class PostgresMissing(RuntimeError):
    """No PostgreSQL server binaries here (Debian's `postgresql` package installs them)."""


def server_binaries() -> Path:
    """The folder of initdb and pg_ctl: $BURNEDGE_TEST_PG_BIN, else the newest /usr/lib/postgresql/*/bin."""
    configured = os.environ.get("BURNEDGE_TEST_PG_BIN")
    candidates = [configured] if configured else sorted(glob.glob("/usr/lib/postgresql/*/bin"), reverse=True)
    for folder in candidates:
        if folder and (Path(folder) / "initdb").exists() and (Path(folder) / "pg_ctl").exists():
            return Path(folder)
    found = shutil.which("initdb")
    if found and shutil.which("pg_ctl"):
        return Path(found).parent
    raise PostgresMissing("PostgreSQL is not installed (apt-get install postgresql, or set BURNEDGE_TEST_PG_BIN)")


class PostgresServer:
    """A throwaway PostgreSQL cluster; start() it, make databases with create_database(), stop() it."""

    def __init__(self, max_connections: int = 200):
        self.bin = server_binaries()
        self.max_connections = max_connections
        self.folder = Path(tempfile.mkdtemp(prefix="burnedge-pg-"))
        self.data = self.folder / "data"
        self.port = free_port()
        self.user = "burnedge"
        self._as_postgres = os.geteuid() == 0

    def url(self, database: str = "postgres") -> str:
        return f"postgresql://{self.user}@127.0.0.1:{self.port}/{database}"

    def _run(self, *args: str) -> None:
        command = [str(self.bin / args[0]), *args[1:]]
        if self._as_postgres:
            command = ["runuser", "-u", "postgres", "--", *command]
        result = subprocess.run(command, capture_output=True, text=True, timeout=120, cwd=self.folder)
        if result.returncode != 0:
            raise RuntimeError(f"{args[0]} failed ({result.returncode}): {result.stderr or result.stdout}")

    def start(self) -> PostgresServer:
        if self._as_postgres:
            account = pwd.getpwnam("postgres")
            os.chown(self.folder, account.pw_uid, account.pw_gid)
        self._run("initdb", "-D", str(self.data), "-U", self.user, "--auth=trust", "-E", "UTF8", "--no-sync")
        settings = (
            f"-c listen_addresses=127.0.0.1 -c port={self.port} -c unix_socket_directories={self.folder}"
            f" -c max_connections={self.max_connections} -c fsync=off -c synchronous_commit=off"
            " -c full_page_writes=off -c shared_buffers=64MB"
        )
        self._run("pg_ctl", "-D", str(self.data), "-l", str(self.folder / "server.log"), "-o", settings, "-w", "start")
        return self

    def create_database(self, prefix: str = "t") -> str:
        """A new, empty database; its URL."""
        import psycopg

        name = f"{prefix}_{uuid.uuid4().hex[:12]}"
        with psycopg.connect(self.url(), autocommit=True) as conn:
            conn.execute(f'CREATE DATABASE "{name}"')
        return self.url(name)

    def stop(self) -> None:
        try:
            if self.data.exists():
                self._run("pg_ctl", "-D", str(self.data), "-m", "immediate", "-w", "stop")
        finally:
            shutil.rmtree(self.folder, ignore_errors=True)
