"""What a run had to guess because the photo did not show it: one line each, logged at the end of the run and
listed under ``guessed`` in ``metrics.json`` and the report (``room_init`` also logs a floor it guesses when it
does). A run that guesses goes on; a user knows what to check."""

from __future__ import annotations

from .artifacts import Camera, RoomBox

FLOOR_GUESSES = {
    "ceiling": "the ceiling (parallel, a camera height below the usual ceiling height)",
    "walls": "two walls (up is along both) below the lowest point seen",
    "wall": "one wall and the camera held level, below the lowest point seen or 1.5 camera units",
    "camera": "the camera held level, below the lowest point seen or 1.5 camera units",
}
"""How each ``floor_source`` other than ``floor`` guessed the floor (logged; metrics.json and the report say it)."""


def room_guesses(room: RoomBox) -> list[str]:
    """What a run had to guess about ``room`` because the photo did not show it (empty when nothing)."""
    source = room.extra.get("floor_source", "floor")
    return [] if source == "floor" else [f"no floor in view: the floor plane from {FLOOR_GUESSES[source]}"]


WEAK_FOV = 0.1
"""A vanishing-point FoV of lower confidence is a guess (its lines barely constrain it; the prior about
``fov.vanishing_points.fallback_vfov_deg`` weighs in)."""


def fov_guesses(camera: Camera) -> list[str]:
    """What the FoV estimate guessed: the fallback FoV, or one its lines barely support."""
    if not camera.method.startswith("vanishing_points/"):
        return []
    if camera.method.endswith("/fallback"):
        return [f"the vertical FoV is the fallback {camera.vfov_deg:.1f}°: the photo's lines give no vanishing points"]
    if camera.confidence < WEAK_FOV:
        return [
            f"the vertical FoV {camera.vfov_deg:.1f}° is uncertain: the photo's vanishing points are weak "
            f"(confidence {camera.confidence:.2f}; fov=fixed fov.fixed.vfov_deg=... gives the true one)"
        ]
    return []


def guesses(camera: Camera | None, room: RoomBox | None) -> list[str]:
    """Everything a run guessed, from its estimated camera and its initial room box (either may be absent)."""
    return (fov_guesses(camera) if camera is not None else []) + (room_guesses(room) if room is not None else [])
