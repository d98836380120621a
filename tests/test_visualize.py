"""The pictures' building blocks: the one float → 8-bit conversion, contact sheets, tiles and the crop overlay."""

from __future__ import annotations

import numpy as np
import pytest

from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.method.visualize import contact_sheet, crop_overlay, fit_in_cell, to_uint8


def test_to_uint8_clips_and_rounds_half_up() -> None:
    values = np.array([[-0.2, 0.0, 0.002, 0.5], [0.999, 1.0, 1.7, 0.25]], np.float32)
    out = to_uint8(values)
    assert out.dtype == np.uint8 and out.shape == values.shape
    assert out.tolist() == [[0, 0, 1, 128], [255, 255, 255, 64]]  # 0.5 · 255 = 127.5 goes up


def test_contact_sheet_lays_out_labelled_thumbnails() -> None:
    images = [(f"m{i}", np.full((40, 50, 3), i * 20, np.uint8)) for i in range(5)]
    sheet = contact_sheet(images, columns=3)
    label_height = sheet.shape[0] // 2 - 40
    assert sheet.shape == (2 * (40 + label_height), 3 * 50, 3) and label_height > 0
    assert (sheet[1:39, 51:99] == 20).all()  # the second image, inside its outline
    assert (sheet[40 + label_height + 1 : 2 * 40 + label_height - 1, 101:149] == 255).all()  # no sixth image
    assert (sheet[40:, 50:100] < 255).any()  # its label
    with pytest.raises(PsdrRoomError, match="no images"):
        contact_sheet([])


def test_a_long_label_wraps_after_its_slash() -> None:
    image = np.zeros((40, 60, 3), np.uint8)
    short = contact_sheet([("chair", image)])
    long = contact_sheet([("a_database/a_rather_long_model_name", image)])
    assert long.shape[0] > short.shape[0] and long.shape[1] == short.shape[1] == 60


@pytest.mark.parametrize("centred", [True, False])
def test_an_image_fits_its_cell_by_its_long_side(centred: bool) -> None:
    tile = fit_in_cell(np.zeros((10, 20, 3), np.uint8), 96, centred=centred)
    assert tile.shape == (96, 96, 3)
    top = 24 if centred else 0
    assert (tile[top : top + 48] == 0).all()
    assert (np.delete(tile, np.s_[top : top + 48], axis=0) == 255).all()


def test_crop_overlay_tints_unclean_pixels_and_outlines_crops() -> None:
    photo = np.full((40, 60, 3), 100, np.uint8)
    unclean = np.zeros((40, 60), bool)
    unclean[30:, :10] = True
    out = crop_overlay(photo, unclean=unclean, crops=[("floor", [(20, 5, 50, 25)])])
    assert (out[unclean] == (177, 50, 50)).all() and (photo == 100).all()
    assert (out[5, 20:50] != 100).any(axis=-1).all()  # the window's top edge
    assert (out[30:, 12:18] == 100).all()  # away from both
