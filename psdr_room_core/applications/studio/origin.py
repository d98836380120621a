"""The studio answers only its own page.

Every request to the studio's port (the page, its files, the viewer's WebSocket) must name the studio in ``Host``:
``localhost``, ``127.0.0.1``, ``[::1]`` or the bound host, with the port it came in on; and a request with an
``Origin`` header must come from ``http://`` one of those. Anything else gets 403. Binding 127.0.0.1 alone does not
keep out a web page the user visits: browsers let any page open a WebSocket to any address (and the studio's
controls write files), and a page served under a name of its own that resolves to 127.0.0.1 (DNS rebinding) reads
the studio as its own site, but its requests carry that name in ``Host``.

viser serves the page and the WebSocket from one ``websockets`` server that it makes and keeps to itself;
:func:`own_page_only` puts :func:`refusal` in front of that server's ``process_request`` hook as viser makes it.
"""

from __future__ import annotations

import contextlib
import http
from collections.abc import Awaitable, Callable, Iterator
from typing import Any

import websockets.asyncio.server
from websockets.asyncio.server import ServerConnection
from websockets.http11 import Request, Response

from psdr_room_core.engine.bounded import excerpt
from psdr_room_core.engine.errors import PsdrRoomError

LOOPBACK = ("localhost", "127.0.0.1", "[::1]")
"""The names of this machine a browser may use for the studio."""
ProcessRequest = Callable[[ServerConnection, Request], Awaitable[Response | None] | Response | None]


def _name(host: str) -> str:
    """``host`` as a URL names it (an IPv6 address in brackets), lower case."""
    return f"[{host}]" if ":" in host else host.lower()


def own_hosts(bind_host: str, port: int) -> set[str]:
    """The ``Host`` values that name the studio bound to ``bind_host``:``port`` (lower case)."""
    names = {*LOOPBACK, _name(bind_host)}
    return {f"{name}:{port}" for name in names} | (names if port == 80 else set())  # port 80: browsers leave it out


def refusal(request: Request, bind_host: str, port: int) -> str | None:
    """Why the studio refuses ``request`` (one line naming the header), or None when it comes from its own page."""
    hosts = own_hosts(bind_host, port)
    host, origin = request.headers.get_all("Host"), request.headers.get_all("Origin")
    address = f"http://{_name(bind_host)}:{port}"
    if len(host) != 1 or host[0].lower() not in hosts:
        return f"Host {', '.join(excerpt(repr(h)) for h in host) or '(none)'} is not the studio; open {address}"
    if origin and (len(origin) > 1 or origin[0].lower() not in {f"http://{h}" for h in hosts}):
        return f"Origin {', '.join(excerpt(repr(o)) for o in origin)} is not the studio's page; open {address}"
    return None


def _checked(process_request: ProcessRequest | None, bind_host: str) -> ProcessRequest:
    """``process_request`` behind :func:`refusal`: a refused request gets 403 and its reason, on the port it used."""

    def check(connection: ServerConnection, request: Request) -> Awaitable[Response | None] | Response | None:
        reason = refusal(request, bind_host, int(connection.local_address[1]))
        if reason is not None:
            return connection.respond(http.HTTPStatus.FORBIDDEN, f"psdr-room-studio: {reason}\n")
        return None if process_request is None else process_request(connection, request)

    return check


@contextlib.contextmanager
def own_page_only(bind_host: str) -> Iterator[None]:
    """Within the block, a ``websockets`` server bound to ``bind_host`` (viser's, made and listening when
    ``viser.ViserServer()`` returns) checks every request with :func:`refusal` first; a block that made none fails,
    since the studio would then answer any page."""
    serve = websockets.asyncio.server.serve
    made: list[bool] = []

    def checked_serve(*args: Any, process_request: ProcessRequest | None = None, **kwargs: Any) -> Any:
        made.append(True)
        return serve(*args, process_request=_checked(process_request, bind_host), **kwargs)

    setattr(websockets.asyncio.server, "serve", checked_serve)  # noqa: B010 (a module attribute, swapped back below)
    try:
        yield
    finally:
        setattr(websockets.asyncio.server, "serve", serve)  # noqa: B010
    if not made:
        raise PsdrRoomError(
            "viser made its server without websockets.asyncio.server.serve, so the studio cannot check where requests "
            "come from; install the viser version pyproject.toml names"
        )
