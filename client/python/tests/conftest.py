"""A real ``sable serve`` for the tests: started once on free ports with a fresh database, and
stopped at the end. ``SABLE_BIN`` names the binary (the Rust test that runs this suite sets it);
otherwise the repository's target/release or target/debug build is used."""

from __future__ import annotations

import os
import secrets
import socket
import subprocess
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

from sable_client import Client

REPO = Path(__file__).resolve().parents[3]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _binary() -> Path:
    if os.environ.get("SABLE_BIN"):
        return Path(os.environ["SABLE_BIN"])
    for profile in ("release", "debug"):
        candidate = REPO / "target" / profile / "sable"
        if candidate.is_file():
            return candidate
    raise RuntimeError("no sable binary: set SABLE_BIN or run `cargo build --release -p sable-server`")


@contextmanager
def _serve(db: Path, *extra: str, scheme: str = "http", ca_cert: str | None = None) -> Iterator[str]:
    """Runs ``sable serve`` on ``db`` with two workers of one thread (and ``extra`` flags); yields
    its base URL once it answers (``https`` with ``--tls-cert``, trusting ``ca_cert``)."""
    http, grpc = _free_port(), _free_port()
    log = open(db.with_suffix(".log"), "wb")
    proc = subprocess.Popen(
        [str(_binary()), "serve", "--db", str(db), "--http", f"127.0.0.1:{http}", "--grpc", f"127.0.0.1:{grpc}",
         "--workers", "2", "--threads-per-job", "1", *extra],
        stdout=log,
        stderr=subprocess.STDOUT,
    )
    url = f"{scheme}://127.0.0.1:{http}"
    try:
        with Client(url, timeout=5, token="", ca_cert=ca_cert) as c:
            deadline = time.monotonic() + 60
            while not c.healthy():
                if proc.poll() is not None:
                    raise RuntimeError(f"sable serve exited with {proc.returncode}: {db.with_suffix('.log').read_text()}")
                if time.monotonic() > deadline:
                    raise RuntimeError("sable serve did not answer /healthz within 60 s")
                time.sleep(0.1)
        yield url
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()
        log.close()


@pytest.fixture(scope="session")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """The base URL of a running service with two workers of one thread."""
    with _serve(tmp_path_factory.mktemp("sable") / "sable.db") as url:
        yield url


@pytest.fixture(scope="session")
def token_server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[str, str, str]]:
    """A service that needs bearer tokens: its URL, a user's token and a worker's token."""
    dir = tmp_path_factory.mktemp("sable-tokens")
    user, worker = "u" + secrets.token_hex(16), "w" + secrets.token_hex(16)
    (dir / "users").write_text(f"# users\n{user}\n")
    (dir / "workers").write_text(f"{worker}\n")
    with _serve(dir / "sable.db", "--user-tokens", str(dir / "users"), "--worker-tokens", str(dir / "workers")) as url:
        yield url, user, worker


@pytest.fixture(scope="session")
def tls_server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[str, str]]:
    """A service over TLS: its https URL and its self-signed certificate's file. The Rust test
    that runs this suite makes the certificate and key (``SABLE_TEST_TLS_CERT``,
    ``SABLE_TEST_TLS_KEY``)."""
    cert, key = os.environ.get("SABLE_TEST_TLS_CERT"), os.environ.get("SABLE_TEST_TLS_KEY")
    if not (cert and key):
        pytest.skip("SABLE_TEST_TLS_CERT and SABLE_TEST_TLS_KEY are not set (server/tests/python_client.rs sets them)")
    db = tmp_path_factory.mktemp("sable-tls") / "sable.db"
    with _serve(db, "--tls-cert", cert, "--tls-key", key, scheme="https", ca_cert=cert) as url:
        yield url, cert


@pytest.fixture()
def sable(server: str) -> Iterator[Client]:
    """A client of the test service."""
    with Client(server) as c:
        yield c


@pytest.fixture(autouse=True)
def _scenes(monkeypatch: pytest.MonkeyPatch) -> None:
    """Named scenes come from the repository's scenes/ folder, wherever pytest runs."""
    monkeypatch.setenv("SABLE_SCENES", str(REPO / "scenes"))
