"""psdr-room's own eyes: a perception network trained on the project's renders and shipped in the package.

- :mod:`.labels`: its classes; :mod:`.encoder`: the bundled NanoDet-g read from its ONNX as a torch module;
  :mod:`.network`: encoder + heads, ONNX export; :mod:`.data`: packs, augmentation, targets;
  :mod:`psdr_room_core.applications.train`: ``psdr-room-train``; :mod:`.decode`: what the outputs mean (numpy);
- :mod:`.perception`: ``segmentation=eyes``, ``depth=eyes`` and ``detector=eyes`` (onnxruntime only);
  :mod:`.with_nanodet`: ``detector=nanodet_eyes`` (``detector=auto``'s choice on a bare photo), NanoDet's boxes
  and the eyes boxes that add to them; :mod:`.with_layout`: ``segmentation=layout_eyes`` (``segmentation=auto``'s
  choice on a bare photo), layout's box room fitted to the eyes walls, floor and ceiling too; all registered by
  :mod:`.plugin` (the entry point; this package imports nothing, so training runs with torch, onnx and cv2).

The data it learns from comes from ``psdr-room-synth-data`` (:mod:`psdr_room_core.applications.synth_data`).
"""
