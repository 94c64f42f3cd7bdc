"""Shared fixtures: a real SQLite file per test, the real app, real accounts."""

from __future__ import annotations

import faulthandler
from collections.abc import Iterator
from pathlib import Path

import pytest
from litestar.testing import TestClient

from base.accounts.permissions import Principal
from gateway.app import create_app
from gateway.dependencies import Services
from gateway.storage.database import Database
from harness.processes import PASSWORD, REPO, GatewayProcess, free_port, login
from schemas.accounts import Role, UserCreate
from schemas.config import Config, GatewayConfig, SecurityConfig

SHARED = REPO.parent / "shared"
# Argon2 at its cheapest: tests exercise the logic, the benchmark measures the real cost.
FAST_SECURITY = SecurityConfig(argon2_time_cost=1, argon2_memory_kib=8, argon2_parallelism=1)
CONSULTANT = Principal("u-consultant", "consult", Role.consultant, None, "session")
"""A center's consultant as the case service sees one, for tests that call it without signing in."""


@pytest.fixture
def config(tmp_path: Path) -> Config:
    return Config(gateway=GatewayConfig(database=str(tmp_path / "gateway.sqlite3")), security=FAST_SECURITY)


@pytest.fixture
def app(config: Config):
    return create_app(config)


@pytest.fixture
def services(app) -> Services:
    return app.state.services


@pytest.fixture
def client(app) -> Iterator[TestClient]:
    with TestClient(app) as c:
        yield c


def make_user(services: Services, username: str, role: Role) -> None:
    services.accounts.create_user(None, UserCreate(username=username, password=PASSWORD, role=role))


@pytest.fixture
def auth(client, services) -> dict[str, dict[str, str]]:
    """Authorization headers for one logged-in user of each role, keyed by role name."""
    for role in Role:
        make_user(services, role.value, role)
    return {role.value: login(client, role.value) for role in Role}


@pytest.fixture
def gateway_process(tmp_path: Path) -> Iterator[GatewayProcess]:
    process = GatewayProcess(tmp_path / "served.sqlite3", free_port())
    yield process
    process.stop()


@pytest.fixture
def sites(tmp_path: Path):
    """A clinic gateway and a burn center set up (keys, enrolment, accounts), neither started; stopped after."""
    from harness.sites import Sites

    sites = Sites(tmp_path)
    sites.set_up()
    yield sites
    sites.stop()


@pytest.fixture(scope="session")
def postgres_server():
    """A real PostgreSQL server for the whole session, started on first use (Debian's packages, a temporary folder,
    loopback). Skipped only on a machine without it and without root; as root the bootstrap installs it, so there
    it must be found."""
    import os

    from harness.postgres import PostgresMissing, PostgresServer

    try:
        server = PostgresServer()
    except PostgresMissing as exc:
        if os.geteuid() == 0:
            raise
        pytest.skip(f"{exc}; tests of the center's PostgreSQL backend skipped")
    server.start()
    yield server
    server.stop()


def start_orthanc():
    """A real Orthanc with its DICOMweb plugin (harness/orthanc.py), started; skipped only on a machine without it
    and without root (as root the bootstrap installs it, so there it must be found)."""
    import os

    from harness.orthanc import OrthancMissing, OrthancServer

    try:
        server = OrthancServer()
    except OrthancMissing as exc:
        if os.geteuid() == 0:
            raise
        pytest.skip(f"{exc}; tests against a real PACS skipped")
    return server.start()


@pytest.fixture(scope="module")
def orthanc():
    """One Orthanc for a test module (loopback, temporary storage), stopped after it."""
    server = start_orthanc()
    yield server
    server.stop()


@pytest.fixture(params=["sqlite", "postgres"])
def center_database(request, tmp_path: Path) -> str:
    """[central] database for a test run against both backends: a SQLite file, or a fresh PostgreSQL database."""
    if request.param == "sqlite":
        return str(tmp_path / "center.sqlite3")
    return request.getfixturevalue("postgres_server").create_database("center")


def open_db(path: str | Path) -> Database:
    return Database(path)


# Modules that load the big native libraries (pycolmap, Open3D, SciPy's spatial code, onnxruntime). They run
# after the gateway's threaded tests: CI once crashed (SIGSEGV, no traceback) in an upload test that ran after
# these libraries were loaded in the same process, and never when they were not. The gateway itself will run
# analyses in a separate worker process for the same reason.
NATIVE_MODULES = {
    "test_reconstruction.py",
    "test_phantom.py",
    "test_burn_surface.py",
    "test_analysis.py",
    "test_segmentation.py",
}


def pytest_collection_modifyitems(session, config, items) -> None:
    items.sort(key=lambda item: item.path.name in NATIVE_MODULES)  # stable: each group keeps its order


@pytest.hookimpl(tryfirst=True)
def pytest_runtest_setup(item) -> None:
    # pycolmap installs glog's crash handler over Python's on import; glog writes into pytest's capture, which
    # dies with the process, so a crash would leave no trace. Put Python's handler (on the real stderr) back.
    from _pytest.faulthandler import fault_handler_stderr_fd_key

    fd = item.config.stash.get(fault_handler_stderr_fd_key, None)
    if fd is not None:
        faulthandler.disable()  # enable() alone would keep the replaced handler: it only installs once
        faulthandler.enable(file=fd, all_threads=True)


@pytest.fixture(scope="module")
def playwright():
    """Playwright for a module's page tests: one per module (a second one in the same process fails)."""
    from playwright.sync_api import sync_playwright

    with sync_playwright() as running:
        yield running


@pytest.fixture(scope="module")
def browser(playwright):
    """Headless Chromium for a module's page tests (harness/browser.py)."""
    from harness.browser import launch

    browser = launch(playwright)
    yield browser
    browser.close()
