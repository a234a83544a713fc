"""batch --scheduler at addresses that are not a working Dask scheduler: never a hang
beyond the documented timeout (``executors.CONNECT_TIMEOUT`` bounds the whole
client handshake), one line, exit 2, and no --out folder left behind.

The servers are started here on 127.0.0.1 and stopped at the end of each test:
one that accepts connections and never answers, and an HTTP server.
"""

import contextlib
import http.server
import os
import socket
import subprocess
import sys
import threading

import pytest

pytest.importorskip("distributed")

from brdf_fit.batch import executors  # noqa: E402
from brdf_fit.cli import main  # noqa: E402

from test_cli_corpus import FAST, _samples  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TIMEOUT = 2.0               # CONNECT_TIMEOUT for these tests
HANG_LIMIT = 300.0          # a subprocess still running after this is a hang (a loaded machine)


@contextlib.contextmanager
def tcp_server(on_connection):
    """A TCP server on 127.0.0.1 that hands every connection it accepts to
    ``on_connection(conn)`` and closes the connections at the end; yields its address."""
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(16)
    held, stop = [], threading.Event()

    def accept():
        server.settimeout(0.2)
        while not stop.is_set():
            try:
                conn = server.accept()[0]
            except (TimeoutError, socket.timeout):
                continue
            except OSError:
                return
            held.append(conn)
            on_connection(conn)

    thread = threading.Thread(target=accept, daemon=True)
    thread.start()
    try:
        yield f"tcp://127.0.0.1:{server.getsockname()[1]}"
    finally:
        stop.set()
        thread.join(timeout=10)
        for conn in held:
            conn.close()
        server.close()


def silent_server():
    """A TCP server that accepts every connection and never sends a byte."""
    return tcp_server(lambda conn: None)


def _reply_in_http(conn):
    try:
        conn.settimeout(5)
        conn.recv(4096)
        conn.sendall(b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n")
    except OSError:
        pass
    conn.close()


def replying_server():
    """A TCP server that answers whatever it is sent with an HTTP/1.1 error (read as a
    Dask frame header: "HTTP/1.1" is a length of 3.07 EiB)."""
    return tcp_server(_reply_in_http)


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):      # the test reads the command's stderr, not the server's log
        pass


@contextlib.contextmanager
def http_server():
    """An HTTP server on 127.0.0.1 (what a dashboard address would give)."""
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), _QuietHandler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"tcp://127.0.0.1:{server.server_address[1]}"
    finally:
        server.shutdown()
        server.server_close()
        thread.join(timeout=10)


def test_a_server_replying_in_another_protocol_is_named_in_one_line(tmp_path, capsys, monkeypatch):
    """Its reply was read as a frame of exabytes: "MemoryError: 3.07 EiB" used to be the message."""
    monkeypatch.setattr(executors, "CONNECT_TIMEOUT", TIMEOUT)
    out = tmp_path / "out"
    with replying_server() as address:
        code = main(["batch", str(_samples(tmp_path / "good.npz")), "--out", str(out), "--scheduler", address,
                     *FAST])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "Memory" not in err, err
    assert err == (f"brdf-fit batch: error: no Dask scheduler at {address}: the server there answered, but "
                   "not in Dask's protocol (is another kind of server listening there?)\n")
    assert not out.exists()


@pytest.mark.parametrize("server", [silent_server, http_server], ids=["silent", "http"])
def test_a_server_that_never_answers_like_a_scheduler(tmp_path, capsys, monkeypatch, server):
    monkeypatch.setattr(executors, "CONNECT_TIMEOUT", TIMEOUT)
    good = _samples(tmp_path / "good.npz")
    out = tmp_path / "out"
    with server() as address:
        code = main(["batch", str(good), "--out", str(out), "--scheduler", address, *FAST])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "Traceback" not in err, err
    assert err.startswith(f"brdf-fit batch: error: no answer from a Dask scheduler at {address} within "
                          f"{TIMEOUT:g} s"), err
    assert not out.exists()


def test_an_unreachable_scheduler_leaves_no_output_folder(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(executors, "CONNECT_TIMEOUT", TIMEOUT)
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]          # closed again: nothing listens there
    out = tmp_path / "new" / "out"
    code = main(["batch", str(_samples(tmp_path / "good.npz")), "--out", str(out),
                 "--scheduler", f"tcp://127.0.0.1:{port}", *FAST])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1, err
    assert f"tcp://127.0.0.1:{port}" in err
    assert not (tmp_path / "new").exists()


@pytest.mark.parametrize("address", ["bogus", "tcp://[::1", "tcp://127.0.0.1:notaport"])
def test_a_malformed_address_is_one_line_even_at_exit(tmp_path, address):
    """In a process of its own: distributed's Client.__del__ used to print a
    traceback at exit after the error line."""
    good = _samples(tmp_path / "good.npz")
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.run([sys.executable, "-m", "brdf_fit", "batch", str(good), "--out",
                           str(tmp_path / "out"), "--scheduler", address, *FAST],
                          cwd=tmp_path, env=env, capture_output=True, text=True, timeout=HANG_LIMIT)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"brdf-fit batch: error: --scheduler {address}: "), \
        proc.stderr
    assert not (tmp_path / "out").exists()
