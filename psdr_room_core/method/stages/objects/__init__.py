"""The object stages (paper §4.3), a module each: :mod:`.group` (one object per thing), :mod:`.retrieve` (the
model search), :mod:`.place` (initial poses) and :mod:`.fit` (the joint refinement, eq. 3). Nothing is
re-exported: each stage is registered by its own module, imported when the stage first computes."""
