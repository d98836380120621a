"""psdr-room-studio answers only its own page: requests (the page's files and the viewer's WebSocket) whose ``Host``
or ``Origin`` is not the studio's own address get 403, so a web page the user visits cannot drive the studio, by a
cross-site WebSocket or by a name of its own resolving to 127.0.0.1 (DNS rebinding). One studio, started as a user
starts it, answers raw HTTP requests and WebSocket handshakes; the rule itself is checked without a server."""

from __future__ import annotations

import base64
import os
import shutil
import socket
import subprocess
from collections.abc import Iterator
from types import SimpleNamespace

import pytest
import viser
import websockets.exceptions
import websockets.sync.client
from test_studio import Studio
from websockets.datastructures import Headers
from websockets.http11 import Request
from websockets.typing import Origin, Subprotocol

from conftest import EXAMPLE
from psdr_room_core.applications.studio.origin import refusal

EVIL = "evil.example"


@pytest.fixture(scope="module")
def port(tmp_path_factory: pytest.TempPathFactory) -> Iterator[int]:
    """The port of a studio on a copy of the bundled example (its preview runs meanwhile; Ctrl-C at the end)."""
    root = tmp_path_factory.mktemp("origin")
    for name in ("photo.jpg", "photo.labelme.json", "photo.depth.png", "photo.depth.json"):
        shutil.copy(EXAMPLE.with_name(name), root / name)
    studio = Studio(SimpleNamespace(photo=root / "photo.jpg", cache=root / "cache"), root / "run")
    yield int(studio.url.rstrip("/").rsplit(":", 1)[1])
    studio.stop()


def status(port: int, headers: dict[str, str], upgrade: bool) -> int:
    """The HTTP status the studio answers ``GET /`` with ``headers`` (and a WebSocket handshake's, if ``upgrade``)."""
    if upgrade:
        headers = {
            **headers,
            "Upgrade": "websocket",
            "Connection": "Upgrade",
            "Sec-WebSocket-Key": base64.b64encode(os.urandom(16)).decode(),
            "Sec-WebSocket-Version": "13",
        }
    request = "GET / HTTP/1.1\r\n" + "".join(f"{k}: {v}\r\n" for k, v in headers.items()) + "\r\n"
    with socket.create_connection(("127.0.0.1", port), timeout=30) as connection:
        connection.sendall(request.encode())
        return int(connection.makefile("rb").readline().split()[1])


def own_and_foreign(port: int) -> list[tuple[dict[str, str], int]]:
    """Request headers and the status each must get: the studio's own addresses, then pages from elsewhere."""
    own = [
        ({"Host": f"{name}:{port}", "Origin": f"http://{name}:{port}"}, 0)
        for name in ("127.0.0.1", "localhost", "LocalHost", "[::1]")
    ]
    own.append(({"Host": f"127.0.0.1:{port}"}, 0))  # a client that is not a browser
    foreign = [
        {"Host": f"127.0.0.1:{port}", "Origin": f"http://{EVIL}"},  # a cross-site page's WebSocket
        {"Host": f"127.0.0.1:{port}", "Origin": f"http://{EVIL}:{port}"},
        {"Host": f"127.0.0.1:{port}", "Origin": "null"},  # a sandboxed frame or a file:// page
        {"Host": f"127.0.0.1:{port}", "Origin": f"https://127.0.0.1:{port}"},
        {"Host": f"127.0.0.1:{port}", "Origin": "http://localhost:3000"},  # another local server's page
        {"Host": f"{EVIL}:{port}", "Origin": f"http://{EVIL}:{port}"},  # DNS rebinding: evil.example → 127.0.0.1
        {"Host": f"{EVIL}:{port}"},
        {"Host": f"127.0.0.1:{port + 1}"},
        {"Host": "127.0.0.1"},
        {},
    ]
    return [*own, *((headers, 403) for headers in foreign)]


def test_websocket_handshakes_from_other_pages_are_refused(port: int) -> None:
    for headers, refused in own_and_foreign(port):
        assert status(port, headers, upgrade=True) == (refused or 101), headers


def test_http_requests_from_other_pages_are_refused(port: int) -> None:
    for headers, refused in own_and_foreign(port):
        assert status(port, headers, upgrade=False) == (refused or 200), headers


def test_a_websocket_client_gets_the_viewer_only_from_the_studios_page(port: int) -> None:
    """viser's own handshake (its version as the subprotocol): refused from another page, and from the studio's
    page the viewer's first messages arrive."""
    viewer = [Subprotocol(f"viser-v{viser.__version__}")]
    with pytest.raises(websockets.exceptions.InvalidStatus, match="403"):
        websockets.sync.client.connect(
            f"ws://127.0.0.1:{port}", origin=Origin(f"http://{EVIL}"), subprotocols=viewer, open_timeout=30
        )
    with websockets.sync.client.connect(
        f"ws://localhost:{port}", origin=Origin(f"http://localhost:{port}"), subprotocols=viewer, open_timeout=30
    ) as connection:
        assert isinstance(connection.recv(timeout=30), bytes)


def test_the_refusal_names_the_header_and_the_studios_address() -> None:
    def request(**headers: str) -> Request:
        return Request("/", Headers(**headers))

    assert refusal(request(Host="127.0.0.1:8080"), "127.0.0.1", 8080) is None
    assert refusal(request(Host="localhost", Origin="http://localhost"), "127.0.0.1", 80) is None
    assert refusal(request(Host="[::1]:8080"), "127.0.0.1", 8080) is None
    reason = refusal(request(Host=f"{EVIL}:8080"), "127.0.0.1", 8080)
    assert reason is not None and f"Host '{EVIL}:8080'" in reason and "http://127.0.0.1:8080" in reason
    reason = refusal(request(Host="127.0.0.1:8080", Origin="http://" + "x" * 500), "127.0.0.1", 8080)
    assert reason is not None and "Origin 'http://xxx" in reason and len(reason) < 250
    two_hosts = Headers([("Host", "127.0.0.1:8080"), ("Host", f"{EVIL}:8080")])
    assert refusal(Request("/", two_hosts), "127.0.0.1", 8080) is not None


def test_help_states_the_rule() -> None:
    result = subprocess.run(
        [shutil.which("psdr-room-studio") or "psdr-room-studio", "--help"], capture_output=True, text=True, timeout=120
    )
    assert result.returncode == 0 and "localhost, 127.0.0.1 or [::1]" in result.stdout, result.stdout
