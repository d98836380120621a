"""``psdr-room-studio image=PHOTO [psdr-room overrides] [studio.port=N] [studio.run_dir=DIR]``.

Starts the studio on 127.0.0.1 (only), prints its address, runs the preview and serves until Ctrl-C. The
overrides are ``psdr-room``'s, checked the same way before anything starts. The studio answers only its own page
(:mod:`.origin`).
"""

from __future__ import annotations

import faulthandler
import logging
import os
import signal
import socket
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, NoReturn

from psdr_room_core.engine import threads
from psdr_room_core.engine.cli import compose_config, preflight
from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.engine.run import resolve_config
from psdr_room_core.libraries.object_db.opening import open_database

from .origin import own_page_only
from .session import PREVIEW, Session, studio_plugins

HOST = "127.0.0.1"
STOP_S = 20.0  # the longest a Ctrl-C may take: past it the studio prints every thread's stack and exits (status 1)
SETTINGS = {"port": "a free port", "run_dir": "outputs/studio/<photo stem>"}
USAGE = "usage: psdr-room-studio image=PHOTO [psdr-room overrides...] " + " ".join(
    f"[studio.{key}=...]" for key in SETTINGS
)
HELP = (
    "The studio listens on 127.0.0.1 and answers only its own page: a request whose Host, or Origin when it has one,\n"
    "is not localhost, 127.0.0.1 or [::1] with the studio's port gets 403 (another site's page cannot drive it).\n"
    "Open the printed address; to reach it over SSH, forward the same port number (ssh -L PORT:127.0.0.1:PORT)."
)


def _fail(message: str) -> NoReturn:
    print(f"psdr-room-studio: error: {message}", file=sys.stderr)
    sys.exit(2)


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind((HOST, 0))
        return int(probe.getsockname()[1])


def studio_settings(argv: list[str]) -> tuple[dict[str, str], list[str]]:
    """Split ``studio.KEY=VALUE`` settings from the pipeline's overrides."""
    settings, overrides = {}, []
    for arg in argv:
        if arg.startswith("studio."):
            key, _, value = arg.removeprefix("studio.").partition("=")
            if key not in SETTINGS:
                raise PsdrRoomError(f"{arg}: unknown studio setting; use {', '.join(f'studio.{k}' for k in SETTINGS)}")
            settings[key] = value
        else:
            overrides.append(arg)
    if "port" in settings and not (settings["port"].isdigit() and 0 < int(settings["port"]) < 65536):
        raise PsdrRoomError(f"studio.port={settings['port']}: not a port number; give one from 1 to 65535")
    return settings, overrides


def open_session(argv: list[str]) -> tuple[Session, dict[str, str], object]:
    """The session, the studio's settings and the object database the run's retrieval uses."""
    settings, overrides = studio_settings(argv)
    session_overrides = [arg for arg in overrides if not arg.startswith("image=")]
    plugins, events = studio_plugins()
    preflight(overrides, plugins)
    data = resolve_config(compose_config(overrides, plugins))
    photo = Path(str(data["image"])).expanduser()
    run_dir = Path(settings.get("run_dir") or Path("outputs") / "studio" / photo.stem)
    session = Session(photo, session_overrides, run_dir, plugins, events)
    retrieval = data.get("retrieval") or {}
    implementation = retrieval.get("impl")
    order = [implementation] if implementation != "auto" else list(retrieval.get("auto", {}).get("order") or [])
    source = next(
        (retrieval[name]["database"] for name in order if "database" in (retrieval.get(name) or {})), "builtin"
    )
    return session, settings, open_database(str(source), 1.0, 0)


def main(argv: list[str] | None = None) -> None:
    """Entry point of ``psdr-room-studio``."""
    args = sys.argv[1:] if argv is None else argv
    if not args or args[0] in ("-h", "--help"):
        print(USAGE + ("\n\n" + HELP if args else ""))
        sys.exit(0 if args else 2)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    faulthandler.register(signal.SIGUSR1, all_threads=True)  # `kill -USR1 PID` prints every thread's stack
    for stop in (signal.SIGINT, signal.SIGTERM):  # Ctrl-C and kill stop it, even started as a background job (SIGINT
        signal.signal(
            stop, signal.default_int_handler
        )  # ignored there, and Python then installs no handler of its own)
    try:
        session, settings, database = open_session(args)
        threads.apply(threads.allotment(None)[0])
    except PsdrRoomError as exc:
        _fail(str(exc))
    import viser

    from .app import StudioApp

    port = int(settings.get("port") or free_port())
    try:
        with own_page_only(HOST):
            server = viser.ViserServer(host=HOST, port=port, label="psdr-room studio", verbose=False)
    except OSError as exc:
        _fail(f"studio.port={port}: cannot listen there ({exc.strerror}); choose another port or leave it out")
    except PsdrRoomError as exc:
        _fail(str(exc))
    library = session.plugins.registry.implementation("material_graph", "torch_graph").factory()
    serve_until_interrupted(server, session, lambda: StudioApp(session, server, database, library))


def serve_until_interrupted(server: Any, session: Session, make_app: Callable[[], Any]) -> NoReturn:
    """Make the page, start the preview, print the address and serve until Ctrl-C (or SIGTERM); then stop the server
    and exit at once, within :data:`STOP_S`.

    The exit does not wait for work still in flight: a run (it may be a full fit of minutes) is abandoned as the
    CLI's Ctrl-C abandons it, and so are the viewer's callbacks, which the interpreter would otherwise join at exit.
    Nothing is left half-written: cache entries, the run folder and the studio's files are renamed into place whole
    (an abandoned run may leave its scratch folders: the cache's, which the next run clears, and one under the
    system's temporary folder)."""
    try:
        make_app().start_run(PREVIEW)
        print(
            f"psdr-room-studio: http://{HOST}:{server.get_port()}  (photo {session.photo}, run folder "
            f"{session.run_dir}; Ctrl-C stops)",
            flush=True,
        )
        while True:
            time.sleep(1.0)
    except KeyboardInterrupt:
        pass
    faulthandler.dump_traceback_later(STOP_S, exit=True)
    abandoned = session.running
    server.stop()
    print(
        "psdr-room-studio: stopped" + (" (the run or edit in progress was abandoned)" if abandoned else ""), flush=True
    )
    logging.shutdown()
    sys.stderr.flush()
    os._exit(0)
