"""The method's stages, one module per paper section (registered by :mod:`psdr_room_core.method.plugin`)."""
