"""Furniture that stands with its back to a wall (§4.3's front/back ambiguity, settled by how rooms are furnished).

Masks and depth seen from one side leave a model's front and its back nearly alike, and a wrong turn can score
best: a bed posed with its headboard towards the camera hides its mattress behind a standing slab
(sunrgbd_total3d_05). Beds, wardrobes, dressers, bookcases, kitchen units and refrigerators stand with their
backs to a wall, so a photo shows them from the front or the side, never from behind: a pose of a model of a
:data:`BACKED` category that turns its back to the camera costs ``back_weight`` × :func:`back_shown` in the view
search (:class:`~psdr_room_core.method.view_search.ViewFit`) and in eq. 3.

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
