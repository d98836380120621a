"""Furniture that stands with its back to a wall (§4.3's front/back ambiguity, settled by how rooms are furnished).

Masks and depth seen from one side leave a model's front and its back nearly alike, and a wrong turn can score
best: a bed posed with its headboard towards the camera hides its mattress behind a standing slab
(sunrgbd_total3d_05). Beds, wardrobes, dressers, bookcases, kitchen units and refrigerators stand with their
backs to a wall, so a photo shows them from the front or the side, never from behind: a pose of a model of a
:data:`BACKED` category that turns its back to the camera costs ``back_weight`` × :func:`back_shown` in the view
search (:class:`~psdr_room_core.method.view_search.ViewFit`) and in eq. 3. Seen from its foot, a bed turned a
quarter turn shows its side, not its back, and a mask and a shallow depth may fit it as well
(sunrgbd_000017_mmdet3d): the wall a model backs onto is the one nearest it, so a pose whose back points at a
farther wall costs ``wall_weight`` × :func:`wall_gap` in the view search and in eq. 3.

Sofas, desks, chairs and tables are left out: a sofa facing a television from the middle of a room and rows
of classroom desks are photographed from behind.
"""

from __future__ import annotations

from typing import Any

BACKED = frozenset({"bed", "cabinet", "shelf", "refrigerator"})
"""Database categories whose models stand with their back (canonical -Z) to a wall."""


def back_shown(sin_yaw: Any, cos_yaw: Any, towards_x: Any, towards_z: Any) -> Any:
    """How far a model turned by ``yaw`` shows the camera its back: the cosine between its front (``R_y(yaw)``
    applied to +Z, which is ``(sin yaw, 0, cos yaw)``) and the horizontal direction ``(towards_x, towards_z)``
    from the camera to the model, where positive. 0 with its front or side to the camera, 1 with its back square
    on. Floats, numpy arrays or torch tensors (differentiable)."""
    length = (towards_x * towards_x + towards_z * towards_z) ** 0.5 + 1e-9
    cosine = (sin_yaw * towards_x + cos_yaw * towards_z) / length
    return 0.5 * (cosine + abs(cosine))


def wall_gap(sin_yaw: Any, cos_yaw: Any, x: Any, z: Any, half_x: float, half_z: float) -> Any:
    """How much farther (metres) the wall a model turned by ``yaw`` backs onto is than the wall nearest it: the
    distance from its origin ``(x, z)`` along its back (``-(sin yaw, cos yaw)``) to the room's wall, less the
    distance to the nearest wall, in the room's frame (yaw and position relative to the room box, its half sizes
    ``half_x``, ``half_z``; a position outside is taken at the box's side). 0 with its back to the nearest wall.
    Floats, numpy arrays or torch tensors (differentiable)."""

    def smaller(a: Any, b: Any) -> Any:
        return 0.5 * (a + b - abs(a - b))

    def inside(value: Any, half: float) -> Any:
        return -smaller(-smaller(value, half), half)

    x, z = inside(x, half_x), inside(z, half_z)
    back_x, back_z = -sin_yaw, -cos_yaw
    # along the back to the wall on the side it points to, per axis; a back running (nearly) along an axis meets
    # that axis's walls at most 2000 half sizes away (no division by zero, and a float32 minimum stays exact)
    run_x, run_z = -smaller(-abs(back_x), -1e-3), -smaller(-abs(back_z), -1e-3)
    along_x = (half_x - x * back_x / run_x) / run_x
    along_z = (half_z - z * back_z / run_z) / run_z
    nearest = smaller(half_x - abs(x), half_z - abs(z))
    return smaller(along_x, along_z) - nearest
