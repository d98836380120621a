"""psdr-room: one photo of a room to an editable 3D scene (Yan et al. 2023), as a cached plugin DAG."""

__version__ = "0.1.0"
