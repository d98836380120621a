"""``psdr-room-studio``: a local web app (viser) to see a run, correct its estimates and picks, and rerun.

:mod:`.session` holds the photo, the corrections (written as the CLI's own sidecar and override files) and the
runs (the CLI's runner); :mod:`.scene_view` draws a run's artifacts in 3D; :mod:`.app` is the page;
:mod:`.cli` the command. It answers only its own page (:mod:`.origin`): a request whose ``Host``, or ``Origin`` when
it has one, is not ``localhost``, ``127.0.0.1`` or ``[::1]`` with the studio's port gets 403, so no other web page
the user visits can drive it.
"""
