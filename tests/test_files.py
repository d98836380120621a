"""write_whole: a file appears whole or not at all."""

import stat
from pathlib import Path

import pytest

from psdr_room_core.engine.files import write_whole


def test_write_whole_replaces_the_file_and_a_failed_write_leaves_the_old_one(tmp_path: Path) -> None:
    path = tmp_path / "new" / "boxes.yaml"
    write_whole(path, "boxes: []\n")  # the folder is made
    write_whole(path, "boxes: [1]\n")
    assert path.read_text() == "boxes: [1]\n"
    plain = path.with_name("plain.yaml")
    plain.write_text("")
    assert stat.S_IMODE(path.stat().st_mode) == stat.S_IMODE(plain.stat().st_mode)  # as open() makes it
    plain.unlink()
    write_whole(path.with_name("thumb.png"), b"\x89PNG")
    assert path.with_name("thumb.png").read_bytes() == b"\x89PNG"
    with pytest.raises(TypeError):
        write_whole(path, 42)  # type: ignore[arg-type]  # fails after the temporary file is made
    assert path.read_text() == "boxes: [1]\n"
    assert sorted(p.name for p in path.parent.iterdir()) == ["boxes.yaml", "thumb.png"]
