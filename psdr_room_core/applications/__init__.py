"""Applications: the commands and the studio a user runs, built on everything below them.

- :mod:`.studio` (``psdr-room-studio``): the browser studio;
- :mod:`.edit` (``psdr-room-edit``), :mod:`.blender` (``psdr-room-blender``, with :mod:`.blender_scene` run inside
  Blender), :mod:`.summary` (``psdr-room-summary``): exported scenes and runs;
- :mod:`.models` (``psdr-room-models``), :mod:`.db` (``psdr-room-db``), :mod:`.materials` (``psdr-room-materials``):
  model files, the object database and the material library;
- :mod:`.synth` (``psdr-room-synth``), :mod:`.synth_data` (``psdr-room-synth-data``), :mod:`.train`
  (``psdr-room-train``): synthetic rooms, the eyes' data set and their training.

The engine's own commands (``psdr-room``, ``psdr-room-plugins``, ``psdr-room-cache``) stay in
:mod:`psdr_room_core.engine`: they run any pipeline, not this method's.
"""
