"""The bad-input corpus: photos, sidecars of every kind, overrides, run and cache paths, scene folders for
``psdr-room-edit`` and ``psdr-room-blender``; each case is checked by :func:`bad_input.run_case`."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from bad_input import (
    RNG_PHOTO,
    Case,
    cache_dir_is_a_file,
    edit,
    edit_into_users_folder,
    encoded,
    example,
    gif,
    labelme,
    npy,
    overrides,
    part,
    png,
    run_case,
    run_dir_is_a_file,
    run_dir_of_another_app,
    run_dir_with_notes,
    scene_folder,
    users_files_in_run_dir,
    with_sidecar,
)
from conftest import EXAMPLE


# ------------------------------------------------------------------------------------------ the corpus
def blender_elsewhere(folder: Path) -> list[str]:
    """A complete-looking scene folder and a Blender that is not there."""
    scene = scene_folder(folder)
    for name in ("scene.glb", "scene.xml"):
        (scene / name).write_bytes(b"not read")
    return [str(scene), "--blender", "no-such-blender"]


CASES: dict[str, Case] = {
    # photos
    "photo_missing": Case(lambda f: [f"image={f / 'nope.jpg'}"], "nope.jpg: no such file"),
    "photo_empty": Case(lambda f: [f"image={example(f, photo=b'')}"], "photo.jpg: the file is empty"),
    "photo_not_an_image": Case(
        lambda f: [f"image={example(f, photo=b'hello, not a JPEG')}"], "photo.jpg: not an image"
    ),
    "photo_truncated": Case(
        lambda f: [f"image={example(f, photo=EXAMPLE.read_bytes()[:20000])}"], "photo.jpg: damaged or truncated"
    ),
    "photo_directory": Case(lambda f: [f"image={f}"], "is a directory"),
    "photo_gif": Case(lambda f: [f"image={gif(f)}"], "photo.gif: GIF images are not supported"),
    "photo_too_small": Case(lambda f: [f"image={png(f, RNG_PHOTO[:40])}"], "photo.png: 160x40 is too small"),
    "photo_one_pixel": Case(lambda f: [f"image={png(f, RNG_PHOTO[:1, :1])}"], "photo.png: 1x1 is too small"),
    "photo_one_colour": Case(lambda f: [f"image={png(f, np.full((120, 160, 3), 90, np.uint8))}"], "same colour"),
    "photo_too_many_pixels": Case(overrides("load_image.max_pixels=1000"), "over load_image.max_pixels=1000"),
    "photo_path_with_equals": Case(lambda f: [f"image={f / 'my,room=1.jpg'}"], "my,room=1.jpg: no such file"),
    "photo_path_with_comma": Case(lambda f: [f"image={f / 'my,room.jpg'}"], "quote the path"),
    "photo_non_ascii_missing": Case(lambda f: [f"image={f / 'café.jpg'}"], "café.jpg: no such file"),
    "photo_empty_path": Case(lambda f: ["image="], "image= is empty"),
    # sidecars beside the photo
    "boxes_not_yaml": Case(with_sidecar(".boxes.yaml", "boxes: [a, b"), "photo.boxes.yaml: not valid YAML"),
    "boxes_not_a_list": Case(
        with_sidecar(".boxes.yaml", "boxes: 5"), "photo.boxes.yaml: expected a single key 'boxes'"
    ),
    "boxes_three_numbers": Case(
        with_sidecar(".boxes.yaml", "boxes:\n  - {label: sofa, box: [1, 2, 3]}"), "box [1, 2, 3] is not four numbers"
    ),
    "boxes_outside_photo": Case(
        with_sidecar(".boxes.yaml", "boxes:\n  - {label: sofa, box: [10, 10, 900, 900]}"),
        "is outside the 640x480 photo",
    ),
    "boxes_unknown_category": Case(
        with_sidecar(".boxes.yaml", "boxes:\n  - {label: x, category: spaceship, box: [1, 1, 9, 9]}"),
        "category 'spaceship' is unknown",
    ),
    "boxes_unknown_key": Case(
        with_sidecar(".boxes.yaml", "boxes:\n  - {label: sofa, bx: [1, 1, 9, 9]}"), "has unknown key(s) bx"
    ),
    "labelme_not_json": Case(with_sidecar(".labelme.json", "{not json"), "photo.labelme.json: not valid JSON"),
    "labelme_bad_polygon": Case(
        with_sidecar(
            ".labelme.json",
            lambda: labelme(shapes=[{"label": "wall", "points": [[0, 0], [10, 10]], "shape_type": "polygon"}]).encode(),
        ),
        "photo.labelme.json",
    ),
    "panoptic_without_json": Case(with_sidecar(".panoptic.png", b"not a png"), "photo.panoptic.png: no segment JSON"),
    "depth_rgb_8bit": Case(with_sidecar(".depth.png", lambda: encoded(RNG_PHOTO)), "photo.depth.png"),
    "depth_wrong_aspect": Case(
        with_sidecar(".depth.png", lambda: encoded(np.full((100, 400), 2000, np.uint16))),
        "depth is 400x100 but the photo is 640x480",
    ),
    "depth_npy_strings": Case(with_sidecar(".depth.npy", lambda: npy(np.array([["a", "b"]]))), "photo.depth.npy"),
    "depth_json_bad_encoding": Case(
        with_sidecar(".depth.json", '{"encoding": "jpeg"}', beside=(".depth.png",)), "photo.depth.json"
    ),
    # settings
    "iterations_not_a_number": Case(overrides("room_fit.iterations=abc"), "room_fit.iterations=abc is invalid"),
    "iterations_negative": Case(overrides("room_fit.iterations=-3"), "room_fit.iterations=-3 is out of range"),
    "learning_rate_negative": Case(
        overrides("fit_appearance.learning_rates.graph=-1"),
        "fit_appearance.learning_rates.graph=-1.0 is out of range; allowed: a number >= 0",
    ),
    "max_side_zero": Case(overrides("load_image.max_side=0"), "load_image.max_side=0 is out of range"),
    "unknown_nested_stage_key": Case(
        overrides("fit_appearance.learning_rates.glos=1"),
        "fit_appearance.learning_rates.glos is not a setting of fit_appearance.learning_rates",
    ),
    "paint_range_reversed": Case(
        overrides("fit_appearance.paint.albedo=[0.5,0.2]"),
        "fit_appearance.paint.albedo=[0.5, 0.2]: the lowest must be below the highest",
    ),
    "probability_over_one": Case(overrides("place_objects.prune.min_iou=1.5"), "place_objects.prune.min_iou=1.5"),
    "list_of_wrong_length": Case(overrides("init_lights.ceiling_grid=[3]"), "init_lights.ceiling_grid=[3] is invalid"),
    "word_not_a_choice": Case(overrides("renderer.mitsuba.variant=gpu"), "renderer.mitsuba.variant=gpu is not one"),
    "boundary_samples_zero": Case(
        overrides("renderer.mitsuba.spp_boundary=0"), "renderer.mitsuba.spp_boundary=0 is out of range"
    ),
    "mistyped_key": Case(overrides("room_init.ransac_treshold=0.1"), "ransac_treshold"),
    "added_unknown_key": Case(overrides("+room_fit.lr=0.1"), "room_fit.lr is not a setting of room_fit"),
    "unknown_implementation": Case(overrides("fov=nope"), "unknown fov implementation 'nope'"),
    "empty_auto_order": Case(overrides("depth.auto.order=[]"), "depth.auto.order=[] is invalid"),
    "bad_override_syntax": Case(overrides("room_init.ransac_threshold=[0.1"), "invalid override"),
    "no_image": Case(lambda f: [], "image is required; add image=PATH/TO/photo.jpg"),
    "bad_cache_mode": Case(overrides("cache=sometimes"), "cache=sometimes is not a cache mode"),
    "unknown_stage_in_until": Case(overrides("run.until=nope"), "nope"),
    "added_unknown_top_key": Case(overrides("+foo=1"), "foo is not a setting"),
    "added_key_of_mistyped_stage": Case(
        overrides("+room_fti.iterations=3"), "room_fti is not a setting (did you mean room_fit?)"
    ),
    "added_mistyped_run_key": Case(
        overrides("+run.untill=room_fit"), "run.untill is not a setting of run (did you mean until?)"
    ),
    "mistyped_stage": Case(overrides("room_fti.iterations=3"), "room_fti is not a setting (did you mean room_fit?)"),
    "mistyped_run_key": Case(overrides("run.untill=room_fit"), "run.untill is not a setting of run"),
    "added_report_key": Case(overrides("+report.colour=red"), "report.colour is not a setting of report"),
    "report_not_a_bool": Case(overrides("report.enabled=maybe"), "report.enabled=maybe is invalid"),
    "report_alpha_over_one": Case(overrides("report.overlay_alpha=2"), "report.overlay_alpha=2.0 is out of range"),
    "stage_input_misnamed": Case(
        overrides("+room_init._inputs_.clouds=point_cloud"),
        "stage 'room_init': input 'clouds' is not a parameter of its function; expected cloud",
    ),
    "injected_folder_missing": Case(lambda f: [f"image={example(f)}", f"+inject.depth={f / 'nowhere'}"], "nowhere"),
    # run and cache paths
    "run_dir_not_ours": Case(users_files_in_run_dir, "psdr-room did not write"),
    "run_dir_of_another_app": Case(run_dir_of_another_app, "psdr-room did not write"),
    "run_dir_with_users_notes": Case(run_dir_with_notes, "psdr-room did not write"),
    "run_dir_is_a_file": Case(run_dir_is_a_file, "exists and is not a folder"),
    "cache_dir_is_a_file": Case(cache_dir_is_a_file, "not_a_dir"),
    # scene folders for psdr-room-edit
    "edit_no_scene": Case(
        lambda f: [str(f / "nothing"), "light.scale=2"], "nothing: no appearance.json", "psdr-room-edit"
    ),
    "edit_invalid_json": Case(edit("light.scale=2", appearance="{"), "appearance.json: invalid JSON", "psdr-room-edit"),
    "edit_incomplete_json": Case(
        edit("light.scale=2", appearance='{"parts": []}'), "appearance.json: missing camera", "psdr-room-edit"
    ),
    "edit_name_escapes": Case(
        edit("light.scale=2", appearance={"fixtures": ["../../etc/passwd"]}), "appearance.json", "psdr-room-edit"
    ),
    "edit_out_users_folder": Case(edit_into_users_folder, "--out", "psdr-room-edit"),
    "edit_unknown_key": Case(edit("colour.floor=1"), "edit colour.floor: unknown", "psdr-room-edit"),
    "edit_not_a_number": Case(edit("light.scale=bright"), "edit light.scale: expected a number", "psdr-room-edit"),
    "edit_unknown_part": Case(edit("material.sofa=oak_planks"), "edit material.sofa: no part 'sofa'", "psdr-room-edit"),
    "edit_not_key_value": Case(edit("brighter"), "edit 'brighter': expected KEY=VALUE", "psdr-room-edit"),
    "edit_roughness_out_of_range": Case(
        edit("material.floor.roughness=5"),
        "roughness=5.0 is out of range; allowed: a number from 0 to 1",
        "psdr-room-edit",
    ),
    "edit_colour_out_of_range": Case(
        edit("material.floor.base_color=[2,0,0]"), "base_color=2.0 is out of range", "psdr-room-edit"
    ),
    "edit_graph_param_out_of_range": Case(
        edit("material.floor=red_brick", "material.floor.bricks.gap=40"),
        "bricks.gap=40 is out of range; allowed: 0.05 to 0.3",
        "psdr-room-edit",
    ),
    "scene_texture_size_text": Case(
        edit("light.scale=2", appearance={"texture_size": "abc"}),
        'appearance.json: texture_size="abc" is invalid',
        "psdr-room-edit",
    ),
    "scene_texture_size_zero": Case(
        edit("light.scale=2", appearance={"texture_size": 0}), "texture_size=0 is out of range", "psdr-room-edit"
    ),
    "scene_texture_size_negative": Case(
        edit("light.scale=2", appearance={"texture_size": -5}), "texture_size=-5 is out of range", "psdr-room-edit"
    ),
    "scene_texture_size_huge": Case(
        edit("light.scale=2", appearance={"texture_size": 60000}),
        "texture_size=60000 is out of range; allowed: an integer from 8 to 4096",
        "psdr-room-edit",
    ),
    "scene_roughness_out_of_range": Case(
        edit("light.scale=2", appearance={"parts": [part(roughness=5)]}),
        "part floor: roughness=5 is out of range",
        "psdr-room-edit",
    ),
    "scene_unknown_material": Case(
        edit("light.scale=2", appearance={"parts": [part(kind="procedural", material="no_such_graph")]}),
        "appearance.json: part floor: material 'no_such_graph' is not in the library",
        "psdr-room-edit",
    ),
    "scene_unknown_part_kind": Case(
        edit("light.scale=2", appearance={"parts": [part(kind="glass")]}),
        'part floor: kind="glass" is invalid',
        "psdr-room-edit",
    ),
    "scene_negative_radiance": Case(
        edit(
            "light.scale=2",
            appearance={
                "lights": [{"name": "light_ceiling_1", "kind": "ceiling", "part": None, "radiance": [-1, 5, 5]}]
            },
        ),
        "light light_ceiling_1: radiance=-1 is out of range",
        "psdr-room-edit",
    ),
    "scene_camera_width_text": Case(
        edit(
            "light.scale=2",
            appearance={"camera": {"width": "wide", "height": 120, "fx": 150.0, "fy": 150.0, "cx": 79.5, "cy": 59.5}},
        ),
        'camera.width="wide" is invalid',
        "psdr-room-edit",
    ),
    "scene_part_unknown_key": Case(
        edit("light.scale=2", appearance={"parts": [part(shine=1)]}), "parts[0]: unknown key(s) shine", "psdr-room-edit"
    ),
    # scene folders for psdr-room-blender
    "blender_no_such_folder": Case(
        lambda folder: [str(folder / "nowhere")], "nowhere: no scene.glb", "psdr-room-blender"
    ),
    "blender_scene_without_glb": Case(
        lambda folder: [str(scene_folder(folder))], "scene: no scene.glb", "psdr-room-blender"
    ),
    "blender_not_installed": Case(blender_elsewhere, "no-such-blender: Blender not found", "psdr-room-blender"),
    "blender_zero_samples": Case(
        lambda folder: [str(scene_folder(folder)), "--spp", "0"], "--spp must be at least 1", "psdr-room-blender"
    ),
    "blender_unknown_denoiser": Case(
        lambda folder: blender_elsewhere(folder)[:1] + ["--denoiser", "magic"],
        "unknown denoiser implementation 'magic'",
        "psdr-room-blender",
    ),
}


def test_corpus_is_large() -> None:
    """This file's cases and those of the corpus's other files (``test_bad_input_*.py``), each name once."""
    import test_bad_input_debris
    import test_bad_input_networks
    import test_bad_input_paths
    import test_bad_input_readers
    import test_bad_input_summary

    paths = test_bad_input_paths
    modules = (test_bad_input_debris, test_bad_input_networks, paths, test_bad_input_readers, test_bad_input_summary)
    parts = [CASES, *(m.CASES for m in modules), paths.NAMED_RUN_DIR_CASES]
    names = [name for part in parts for name in part]
    assert len(names) == len(set(names)) and len(names) >= 100


@pytest.mark.parametrize("name", sorted(CASES))
def test_bad_input_gets_one_line(name: str, tmp_path: Path, cli_env: dict[str, str], cache_dir: Path) -> None:
    run_case(CASES[name], tmp_path, cli_env, cache_dir)
