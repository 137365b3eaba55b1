"""A real cleave-server for the tests, started by the test session.

The binaries come from ``$CLEAVE_BIN_DIR`` (default: the repository's
``target/release``, where ``cargo build --release`` puts them); the tests
fail, naming the path, when they are missing, rather than skip.
"""
from __future__ import annotations

import importlib.util
import os
import re
import socket
import struct
import subprocess
import threading
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[3]
SCENES = REPO / "scenes"


def binary(name: str) -> Path:
    d = Path(os.environ.get("CLEAVE_BIN_DIR", REPO / "target" / "release"))
    p = d / name
    if not p.is_file():
        pytest.fail(f"{p} not found: run `cargo build --release` (or set CLEAVE_BIN_DIR)")
    return p


class Server:
    """cleave-server on a free port of 127.0.0.1 with its own data folder."""

    def __init__(self, data: Path, *extra: str):
        self.proc = subprocess.Popen(
            [str(binary("cleave-server")), "--listen", "127.0.0.1:0", "--data-dir", str(data),
             "--threads-per-job", "1", *extra],
            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, env={**os.environ, "RUST_LOG": "warn"},
            text=True)
        line = self.proc.stdout.readline()
        m = re.match(r"listening on (\S+)", line)
        if not m:
            self.proc.kill()
            raise RuntimeError(f"cleave-server said {line!r}")
        self.address = m.group(1)
        self.port = int(self.address.rsplit(":", 1)[1])
        self.url = f"http://{self.address}"

    def stop(self):
        self.proc.kill()
        self.proc.wait()


@pytest.fixture(scope="session")
def server(tmp_path_factory):
    s = Server(tmp_path_factory.mktemp("server"), "--max-concurrent-jobs", "2")
    yield s
    s.stop()


@pytest.fixture
def client(server):
    from cleave_client import Client

    with Client(server.url) as c:
        yield c


def embedded_run(scene: Path, out: Path) -> Path:
    """``cleave run SCENE --out OUT`` in this process's machine, no server."""
    subprocess.run([str(binary("cleave")), "run", str(scene), "--out", str(out), "--quiet"],
                   check=True, stdout=subprocess.DEVNULL)
    return out


def read_vtp(path: Path) -> dict[str, np.ndarray]:
    """The point arrays of a cleave .vtp: the docs' own reader
    (``docs/scripts/crack_band.py``), which the measurements use."""
    spec = importlib.util.spec_from_file_location("crack_band", REPO / "docs" / "scripts" / "crack_band.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.read_vtp(path)


class Proxy:
    """A TCP relay in front of the server whose connections can be cut, as a
    network or a load balancer would cut them; it goes on accepting new
    ones."""

    def __init__(self, port: int):
        self.upstream = ("127.0.0.1", port)
        self.listener = socket.create_server(("127.0.0.1", 0))
        self.url = f"127.0.0.1:{self.listener.getsockname()[1]}"
        self.lock = threading.Lock()
        self.sockets: list[socket.socket] = []
        self.cuts = 0
        threading.Thread(target=self._accept, daemon=True).start()

    def _accept(self):
        while True:
            try:
                down, _ = self.listener.accept()
            except OSError:
                return
            up = socket.create_connection(self.upstream)
            with self.lock:
                self.sockets += [down, up]
            for a, b in ((down, up), (up, down)):
                threading.Thread(target=self._pump, args=(a, b), daemon=True).start()

    @staticmethod
    def _pump(src: socket.socket, dst: socket.socket):
        try:
            while data := src.recv(65536):
                dst.sendall(data)
        except OSError:
            pass
        for s in (src, dst):
            try:
                s.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass

    def cut(self):
        """Drops every open connection (a reset, not a goodbye)."""
        with self.lock:
            socks, self.sockets = self.sockets, []
            self.cuts += 1
        for s in socks:
            try:
                s.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
                s.close()
            except OSError:
                pass

    def close(self):
        self.listener.close()
        self.cut()
