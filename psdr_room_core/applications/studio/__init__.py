"""``psdr-room-studio``: a local web app (viser) to see a run, correct its estimates and picks, and rerun.

:mod:`.session` holds the photo, the corrections (written as the CLI's own sidecar and override files) and the
runs (the CLI's runner); :mod:`.scene_view` draws a run's artifacts in 3D; :mod:`.app` is the page;
:mod:`.cli` the command.
"""
