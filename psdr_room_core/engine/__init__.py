"""The engine: a cached, plugin-based DAG of stages over typed artifacts, composed by Hydra. It knows nothing of
rooms, cameras or renderers (``tests/test_engine_alone.py`` runs a toy pipeline on it alone).

- :mod:`.dag`: the stage graph's names for plugin authors, from :mod:`.stage_config` (stage nodes from config),
  :mod:`.graph` (sorted, checked, sliced by ``run.only/from/until``), :mod:`.context` (what a stage gets),
  :mod:`.choice` (implementations, ``auto``) and :mod:`.runner` (run through the cache); :mod:`.dag_view`:
  ``psdr-room --dag``;
- :mod:`.cache`: the content-addressed store (atomic commits, per-entry locks, damage checks);
- :mod:`.plugins` + :mod:`.hookspecs`: entry-point discovery, the registry, the hook contract;
- :mod:`.artifacts`: the protocol every artifact type satisfies; :mod:`.capabilities`: what ``auto`` asks;
- :mod:`.settings`: typed, range-checked settings; :mod:`.run`: one run, published into its folder;
- :mod:`.cli`, :mod:`.cache_cli`: ``psdr-room``, ``psdr-room-plugins``, ``psdr-room-cache``;
- :mod:`.inputs`, :mod:`.ownership`, :mod:`.threads`, :mod:`.errors`: input files, safe output folders,
  CPU threads, the one-line error.
"""
