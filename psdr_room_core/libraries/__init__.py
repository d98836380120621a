"""Libraries: reusable pieces that stages' implementations, benchmarks and applications share, registered as
nothing themselves.

- :mod:`.object_db`: the object model database (§4.3), its built-in library and 3D-FUTURE reader;
- :mod:`.synth`: synthetic rooms with exact ground truth (generator, ray caster, path-traced photo);
- :mod:`.vanishing_points`: the camera from Manhattan vanishing points;
- :mod:`.sidecar_depth`, :mod:`.sidecar_segmentation`: readers of depth and segmentation files beside a photo;
- :mod:`.llvm`: a usable libLLVM for Dr.Jit and the Mitsuba variant.

They build on the method's types; plugins and applications build on them (``lint-imports`` checks the layers).
"""
