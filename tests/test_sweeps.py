"""Sweeps over a folder of photos (``photos=DIR``): the launchers that run here (Ray, submitit's local
executor, the basic one), a failed photo that does not stop the others, the sweep's summary, and the shared
cache written by four workers at once."""

from __future__ import annotations

import csv
import json
import os
import shutil
import subprocess
from pathlib import Path

import pytest
from hydra.core.override_parser.overrides_parser import OverridesParser

from conftest import EXAMPLE
from psdr_room_core.engine.cache import Store, damage
from psdr_room_core.engine.cli import expand_photos, hydra_quote
from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.engine.inputs import find_photos
from psdr_room_core.libraries.synth import write_scene
from psdr_room_core.libraries.synth.scene import generate

UNTIL_ROOM_FIT = ["run.until=room_fit", "room_fit.iterations=8", "room_fit.render_width=64"]


def psdr_room(*args: str, env: dict[str, str]) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [shutil.which("psdr-room") or "psdr-room", *args], env=env, capture_output=True, text=True, timeout=600
    )


def summary_rows(sweep: Path) -> list[dict[str, str]]:
    return list(csv.DictReader((sweep / "summary.csv").open(encoding="utf-8")))


@pytest.fixture(scope="module")
def rooms(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Four small synthetic rooms in one folder (room0.png ... with their depth and panoptic sidecars)."""
    folder = tmp_path_factory.mktemp("rooms")
    for seed in range(4):
        scene = folder / f"scene{seed}"
        photo = write_scene(generate(seed, width=160, height=120), scene, spp=8)
        for file in scene.glob(f"{photo.stem}.*"):
            file.rename(folder / file.name.replace(photo.stem, f"room{seed}", 1))
        shutil.rmtree(scene)
    return folder


def test_photos_of_a_folder_leave_sidecars_and_other_files_out(rooms: Path, tmp_path: Path) -> None:
    assert [p.name for p in find_photos(str(rooms))] == ["room0.png", "room1.png", "room2.png", "room3.png"]
    assert [p.name for p in find_photos(str(rooms / "room[13].*"))] == ["room1.png", "room3.png"]
    (tmp_path / "IMG.2024.jpg").touch()  # a dotted name is a photo unless IMG.jpg sits beside it
    (tmp_path / "notes.txt").touch()
    assert [p.name for p in find_photos(str(tmp_path))] == ["IMG.2024.jpg"]
    for spec, problem in ((tmp_path / "nowhere", "no such folder"), (tmp_path / "*.webp", "no photos in it")):
        with pytest.raises(PsdrRoomError, match=problem):
            find_photos(str(spec))


def test_photos_become_one_quoted_sweep_value_each(tmp_path: Path) -> None:
    names = ["a b.png", "it's,here.jpg", "${oops}.png", "back\\slash'.png", "[x]=y.png", "end\\.png"]
    for name in names:
        (tmp_path / name).touch()
    argv = expand_photos(["--multirun", f"photos={tmp_path}", "run.until=load_image"])
    override = OverridesParser.create().parse_overrides([argv[1]])[0]
    assert argv[0] == "--multirun" and argv[2] == "run.until=load_image" and override.key_or_group == "image"
    values = [v.text.replace("\\${", "${") for v in override.value().list]  # OmegaConf un-escapes \${ itself
    assert values == [str(p) for p in sorted(tmp_path.iterdir())]
    assert hydra_quote("a'b") == "'a\\'b'"
    with pytest.raises(PsdrRoomError, match="add --multirun"):
        expand_photos([f"photos={tmp_path}"])
    with pytest.raises(PsdrRoomError, match="not both"):
        expand_photos(["-m", f"photos={tmp_path}", "image=x.jpg"])


def test_a_failed_photo_does_not_stop_the_sweep(tmp_path: Path, cli_env: dict[str, str]) -> None:
    """Basic launcher: the broken photo's job fails with its one line, the others finish, the sweep's summary
    lists all of them, and the sweep exits 1."""
    photos = tmp_path / "photos"
    photos.mkdir()
    (photos / "a broken, one.jpg").write_text("not a JPEG")
    shutil.copy(EXAMPLE, photos / "basement's.jpg")
    shutil.copy(EXAMPLE, photos / "z.jpg")
    result = psdr_room(
        "--multirun", f"photos={photos}", "run.until=load_image", f"hydra.sweep.dir={tmp_path / 'sweep'}", env=cli_env
    )
    assert result.returncode == 1, result.stderr
    assert "Traceback" not in result.stderr
    assert f"psdr-room: error: {photos / 'a broken, one.jpg'}: not an image" in result.stderr
    assert "psdr-room: sweep: 3 runs (2 ok, 1 failed)" in result.stderr
    rows = summary_rows(tmp_path / "sweep")
    assert [(Path(r["photo"]).name, r["status"]) for r in rows] == [
        ("a broken, one.jpg", "failed"),
        ("basement's.jpg", "ok"),
        ("z.jpg", "ok"),
    ]
    assert "not an image" in rows[0]["error"]
    assert (tmp_path / "sweep" / "summary.html").read_text(encoding="utf-8").count("data:image/png;base64,") == 2


@pytest.mark.parametrize("launcher", ["ray", "submitit_local"])
def test_a_folder_of_rooms_on_a_launcher(launcher: str, rooms: Path, tmp_path: Path, cli_env: dict[str, str]) -> None:
    """The issue's command on this machine: one job per room in the launcher's workers, summary of all four."""
    sweep = tmp_path / "sweep"
    result = psdr_room(
        "--multirun",
        f"hydra/launcher={launcher}",
        f"photos={rooms}",
        *UNTIL_ROOM_FIT,
        f"hydra.sweep.dir={sweep}",
        env=cli_env,
    )
    assert result.returncode == 0, result.stderr[-3000:]
    rows = summary_rows(sweep)
    assert sorted(Path(r["photo"]).name for r in rows) == [f"room{i}.png" for i in range(4)]
    assert {r["status"] for r in rows} == {"ok"} and all(float(r["room_fit_s"]) > 0 for r in rows)
    assert len({json.loads((Path(r["run"]) / "metrics.json").read_text())["digests"]["room_box"] for r in rows}) == 4
    if launcher == "submitit_local":  # each job's logs in .submitit/<job id>/, no folder named literally %j
        assert (sweep / ".submitit").is_dir() and not (sweep / ".submitit" / "%j").exists()


def test_four_ray_workers_on_one_cache(rooms: Path, tmp_path: Path, cli_env: dict[str, str]) -> None:
    """Four workers at once on one photo: every cache entry computed by exactly one of them, the other three
    waited on its lock or found it committed; then on four photos: nothing torn, nothing left in tmp/."""
    photo = rooms / "room0.png"
    same = psdr_room(
        "--multirun",
        "hydra/launcher=ray",
        "+hydra.launcher.ray.init.num_cpus=4",
        f"image={photo},{photo},{photo},{photo}",
        *UNTIL_ROOM_FIT,
        f"hydra.sweep.dir={tmp_path / 'same'}",
        env=cli_env,
    )
    assert same.returncode == 0, same.stderr[-3000:]
    jobs = [json.loads((tmp_path / "same" / str(i) / "metrics.json").read_text()) for i in range(4)]
    for stage in jobs[0]["stages"]:
        assert sum(not job["stages"][stage]["cached"] for job in jobs) == 1, stage
    assert len({json.dumps(job["digests"], sort_keys=True) for job in jobs}) == 1
    mixed = psdr_room(
        "--multirun",
        "hydra/launcher=ray",
        "+hydra.launcher.ray.init.num_cpus=4",
        f"photos={rooms}",
        *UNTIL_ROOM_FIT,
        f"hydra.sweep.dir={tmp_path / 'mixed'}",
        env=cli_env,
    )
    assert mixed.returncode == 0, mixed.stderr[-3000:]
    store = Store(Path(cli_env["PSDR_ROOM_CACHE_DIR"]))
    entries = list(store.entries())
    assert len(entries) == 4 * len(jobs[0]["stages"]) and not [e for e in entries if damage(e) is not None]
    assert not os.listdir(store.root / "tmp")
