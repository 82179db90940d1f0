import os
import pathlib
import socket
import struct
import threading
import time
import urllib.request

import pytest

import lamina

REPO = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def phantom_model():
    """The built-in phantom with the default options (0.4 s to build; shared, read-only)."""
    return lamina.build_model("phantom")


@pytest.fixture(scope="session")
def cli():
    return lamina.executable()


def front_node(model):
    """The most anterior skin node (smallest y), where the paper pokes."""
    return int(model.X[: model.skin_node_count, 1].argmin())


def back_nodes(model):
    """Nodes within 10 mm of the posterior-most plane: the paper's fixed region."""
    back = model.X[model.X[:, 1].argmax()]
    return lamina.nodes_near_plane(model, back, (0, 1, 0), 10.0)


def free_port():
    """A TCP port nothing listens on now, on 127.0.0.1."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def serve_in_thread(target, **options):
    """Runs target.serve(**options) on a thread (serving releases the GIL); returns the thread
    and a dict that gets its result ("code") or its exception ("error")."""
    out = {}

    def run():
        try:
            out["code"] = target.serve(**options)
        except Exception as e:  # noqa: BLE001 - handed to the test
            out["error"] = e

    t = threading.Thread(target=run)
    t.start()
    return t, out


def fetch_page(port, token, thread, limit_s=120.0):
    """The web page served on `port` while `thread` serves it, or None."""
    deadline = time.monotonic() + limit_s
    while time.monotonic() < deadline and thread.is_alive():
        try:
            with urllib.request.urlopen(f"http://127.0.0.1:{port}/?token={token}",
                                        timeout=5) as r:
                return r.read().decode()
        except OSError:
            time.sleep(0.05)
    return None


def _read_exactly(sock, n):
    data = b""
    while len(data) < n:
        chunk = sock.recv(n - len(data))
        assert chunk, "the server closed the connection"
        data += chunk
    return data


def polydata_points(port, devices, limit_s=60.0):
    """Connects to the OpenIGTLink server on `port` (retrying until it listens) and reads
    messages until a POLYDATA of each of `devices` has come: {device: its point count} (a
    POLYDATA body starts with it) for every POLYDATA seen."""
    deadline = time.monotonic() + limit_s
    while True:
        try:
            c = socket.create_connection(("127.0.0.1", port), timeout=5)
            break
        except OSError:
            assert time.monotonic() < deadline, f"nothing listens on {port}"
            time.sleep(0.05)
    points = {}
    with c:
        while not set(devices) <= set(points) and time.monotonic() < deadline:
            # An OpenIGTLink header: version, type, device, timestamp, body size, CRC.
            _, kind, device, _, size, _ = struct.unpack(">H12s20sQQQ", _read_exactly(c, 58))
            body = _read_exactly(c, size)
            if kind.rstrip(b"\0") == b"POLYDATA":
                points[device.rstrip(b"\0").decode()] = struct.unpack(">I", body[:4])[0]
    return points
