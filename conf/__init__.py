"""psdr-room's Hydra config tree (imported as ``psdr_room_conf`` so Hydra finds it with ``pkg://``)."""
