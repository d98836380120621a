"""psdr-room: one photo of a room to an editable 3D scene (Yan et al. 2023), as a cached plugin DAG.

The tree holds its kinds, each layer importing only those below it (``lint-imports``):

- :mod:`.applications`: the commands and the studio;
- ``psdr_room_plugins`` (``plugins/`` on disk): the built-in entry-point plugins, swappable implementations;
- :mod:`.libraries`: the object database, synthetic rooms, vanishing points, sidecar readers;
- :mod:`.method`: the paper's stages, artifacts and algorithms;
- :mod:`.engine`: the cached DAG, settings, plugins and cache, knowing nothing of rooms.
"""

__version__ = "0.1.0"
