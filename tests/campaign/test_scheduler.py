"""``campaign --scheduler``: one message for every unusable address, within a bounded time, no traceback at
exit, no hang (issue 18's reproducers); a real scheduler is accepted and a worker's address is not."""

import http.server
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from postcapture.core.errors import ScenarioError
from postcapture.studies.scheduler import CONNECT_TIMEOUT_S, check_scheduler

EXE = str(Path(sys.executable).parent / "postcapture")


@pytest.fixture(scope="module")
def silent_server():
    """A server that accepts connections and never answers."""
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(8)
    yield f"tcp://127.0.0.1:{srv.getsockname()[1]}"
    srv.close()


@pytest.fixture(scope="module")
def http_server():
    class Quiet(http.server.BaseHTTPRequestHandler):
        def log_message(self, *args):
            pass

    httpd = http.server.HTTPServer(("127.0.0.1", 0), Quiet)
    thread = threading.Thread(target=httpd.serve_forever, daemon=True)
    thread.start()
    yield httpd.server_address[1]
    httpd.shutdown()


def _closed_port() -> int:
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


@pytest.mark.parametrize("kind", ["garbage", "empty_tcp", "inproc", "ws", "http", "silent", "closed", "port_range"])
def test_an_unusable_scheduler_gives_one_message_and_no_traceback(kind, silent_server, http_server, tmp_path):
    address = {"garbage": "garbage", "empty_tcp": "tcp://", "inproc": "inproc://x",
               "ws": f"ws://127.0.0.1:{http_server}", "http": f"tcp://127.0.0.1:{http_server}",
               "silent": silent_server, "closed": f"tcp://127.0.0.1:{_closed_port()}",
               "port_range": "tcp://127.0.0.1:70000"}[kind]
    t0 = time.monotonic()
    done = subprocess.run([EXE, "campaign", "--runs", "2", "--duration", "3", "--scheduler", address,
                           "--out", str(tmp_path / "c")], capture_output=True, text=True, timeout=120)
    elapsed = time.monotonic() - t0
    assert done.returncode == 1, done.stderr
    assert "Traceback" not in done.stderr and "Exception ignored" not in done.stderr, done.stderr
    assert done.stderr.count("postcapture: error:") == 1 and "--scheduler: expected the address of a running Dask " \
        "scheduler" in done.stderr and address in done.stderr, done.stderr
    assert elapsed < 60, elapsed  # bounded: it used to hang for more than 300 s on a silent server
    assert not (tmp_path / "c").exists()  # refused before anything was written


def test_a_running_scheduler_is_accepted_and_a_worker_is_not():
    from dask.distributed import Client, LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=":0") as cluster, Client(cluster) as client:
        assert check_scheduler(cluster.scheduler_address) == cluster.scheduler_address
        worker = next(iter(client.scheduler_info()["workers"]))
        with pytest.raises(ScenarioError, match="not a Dask scheduler"):
            check_scheduler(worker)


def test_the_wait_is_bounded(silent_server):
    t0 = time.monotonic()
    with pytest.raises(ScenarioError, match=r"no answer within 1 s"):
        check_scheduler(silent_server, timeout=1.0)
    assert time.monotonic() - t0 < 1.0 + 1.0 + 5.0  # the wait, its guard, and room for a loaded machine
    assert CONNECT_TIMEOUT_S <= 10.0
