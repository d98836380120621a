"""The method: PSDR-Room (Yan et al. 2023) as a plugin of the engine (:mod:`.plugin`, entry point ``core``).

- :mod:`.artifacts`: what the stages pass each other (image & camera, segmentation & depth, geometry, appearance);
- :mod:`.stages`: one module per paper section (§4.1 ``preprocess``, §4.2 ``room``, §4.3 ``objects``, §4.4
  ``materials`` / ``lighting`` / ``appearance``, §5 ``export``);
- the algorithms they use: §4.2 :mod:`.room_box`; §4.3 :mod:`.view_search`, :mod:`.objects`, :mod:`.silhouette`;
  §4.4 :mod:`.material_search`, :mod:`.crops`, :mod:`.surface_colours`, :mod:`.lighting`, :mod:`.shading`,
  :mod:`.rgb_scene`; shared :mod:`.geometry`, :mod:`.photo`, :mod:`.image_metrics`, :mod:`.lpips`;
- :mod:`.capabilities` (the swappable parts and their protocols), :mod:`.hookspecs` (the method's own hooks);
- outputs: :mod:`.gltf`, :mod:`.visualize`; the model-file registry :mod:`.models`.

Its commands live in :mod:`psdr_room_core.applications`.
"""
