"""The plugin registry: entry points, provenance, conflicts, broken plugins, and a real third-party package."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace
from typing import Any, Protocol

import PIL.Image
import pytest

from conftest import EXAMPLE, REPO
from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.engine.hookspecs import hookimpl
from psdr_room_core.engine.plugins import load_plugins
from psdr_room_core.engine.registry import Origin, Registry

BUILTIN_IMPLEMENTATIONS = {("fov", "vanishing_points"), ("fov", "fixed"), ("depth", "file"), ("segmentation", "file")}


def plugin(**hooks: object) -> SimpleNamespace:
    """A plugin object whose attributes are the given hook functions (marked as hookimpls)."""
    return SimpleNamespace(**{name: hookimpl(fn) for name, fn in hooks.items()})


def test_builtins_come_through_entry_points() -> None:
    system = load_plugins()
    assert set(system.registry.implementations) >= BUILTIN_IMPLEMENTATIONS
    origin = system.registry.implementations[("fov", "fixed")].origin
    assert origin.plugin == "fov" and origin.distribution.startswith("psdr-room ")
    assert {"load_image", "room_init", "export_scene"} <= set(system.registry.stages)
    assert not system.registry.failures


def test_unknown_implementation_lists_valid_names() -> None:
    registry = load_plugins().registry
    with pytest.raises(PsdrRoomError, match=r"unknown fov implementation 'nope'; valid names: fixed, vanishing_points"):
        registry.implementation("fov", "nope")


def test_a_plugin_taking_a_builtin_name_is_left_out_naming_both() -> None:
    """A third-party implementation under a built-in's name: the built-in keeps it, and the rival plugin is left out
    with one line naming both plugins, which a run selecting what else it provides gets too."""

    def register(registry):  # noqa: ANN001
        registry.add_implementation("fov", "exif_rival", object)
        registry.add_implementation("fov", "fixed", object)

    rival = Origin("rival", "rival-dist 1.0", "rival = rival")
    system = load_plugins(extra=[(plugin(register_implementations=register), rival)])
    assert system.registry.implementation("fov", "fixed").origin.plugin == "fov"
    why = system.registry.failures["rival"]
    assert why.startswith("registration failed: ValueError: fov=fixed is registered by plugin 'fov' (")
    assert why.endswith(f" and by {rival}; rename one of them") and "\n" not in why
    assert system.registry.conflicts[("fov", "fixed")] == [
        system.registry.implementations[("fov", "fixed")].origin,
        rival,
    ]
    with pytest.raises(
        PsdrRoomError, match="left out: rival: registration failed: ValueError: fov=fixed is registered"
    ):
        system.registry.implementation("fov", "exif_rival")


class Gadget:
    """An artifact type of kind ``gadget``."""

    kind = "gadget"
    marker = "gadget.json"

    def save(self, directory: Path) -> None: ...

    @classmethod
    def load(cls, directory: Path) -> Gadget:
        return cls()


class OtherGadget(Gadget):
    """Another artifact type of the same kind."""


@dataclass
class GadgetSettings:
    size: int = 1


@dataclass
class OtherGadgetSettings:
    size: float = 1.0


def make_gadget(ctx: object) -> Gadget:
    return Gadget()


def make_other_gadget(ctx: object) -> Gadget:
    return Gadget()


KINDS = {
    # kind: (hook, registering it, registering something else under its name, the error's name, conflicts' key)
    "capability": (
        "register_capabilities",
        lambda registry: registry.add_capability("widgets", "makes widgets"),
        lambda registry: registry.add_capability("widgets", "makes widgets", Gadget),
        "capability 'widgets'",
        ("capability", "widgets"),
    ),
    "artifact": (
        "register_artifacts",
        lambda registry: registry.add_artifact(Gadget),
        lambda registry: registry.add_artifact(OtherGadget),
        "artifact kind 'gadget'",
        ("artifact", "gadget"),
    ),
    "implementation": (
        "register_implementations",
        lambda registry: registry.add_implementation("gadgets", "small", Gadget, params=GadgetSettings),
        lambda registry: registry.add_implementation("gadgets", "small", Gadget, version="2", params=GadgetSettings),
        "gadgets=small",
        ("gadgets", "small"),
    ),
    "stage": (
        "register_stages",
        lambda registry: registry.add_stage("make_gadget", make_gadget, uses=["gadgets"]),
        lambda registry: registry.add_stage("make_gadget", make_other_gadget, uses=["gadgets"]),
        "stage 'make_gadget'",
        ("stage", "make_gadget"),
    ),
    "settings": (
        "register_settings",
        lambda registry: registry.add_settings("gadget_shop", GadgetSettings),
        lambda registry: registry.add_settings("gadget_shop", OtherGadgetSettings),
        "settings 'gadget_shop'",
        ("settings", "gadget_shop"),
    ),
}


def _two_plugins(kind: str, second_registers: Callable[[Any], None]) -> Registry:
    """The registry of a plugin declaring capability ``gadgets``, then plugins ``first`` and ``second`` that
    register a ``kind``: the first as in :data:`KINDS`, the second with ``second_registers`` (in a function of its
    own: pluggy refuses a plugin equal to one it has)."""
    hook, first_registers, *_ = KINDS[kind]
    base = plugin(register_capabilities=lambda registry: registry.add_capability("gadgets", "makes gadgets"))
    return load_plugins(
        extra=[
            (base, Origin("base", "base 1", "base = base")),
            (plugin(**{hook: first_registers}), Origin("first", "first 1", "first = first")),
            (
                plugin(**{hook: lambda registry: second_registers(registry)}),
                Origin("second", "second 2", "second = second"),
            ),
        ],
        discover=False,
    ).registry


def _owner(registry: Registry, kind: str) -> Origin | None:
    """The plugin whose registration the registry holds, for the kinds that keep it."""
    if kind == "implementation":
        return registry.implementations[("gadgets", "small")].origin
    if kind == "stage":
        return registry.stages["make_gadget"].origin
    return None


@pytest.mark.parametrize("kind", KINDS)
def test_the_same_registration_twice_changes_nothing(kind: str) -> None:
    """A second plugin registering what the first did (the same object, the same options) is no conflict."""
    registry = _two_plugins(kind, KINDS[kind][1])
    assert not registry.failures and not registry.conflicts
    owner = _owner(registry, kind)
    assert owner is None or owner.plugin == "first"


@pytest.mark.parametrize("kind", KINDS)
def test_a_name_registered_twice_differently_leaves_the_second_plugin_out_naming_both(kind: str) -> None:
    """Whatever the name names, a different registration under it is refused in one line naming both plugins; the
    first keeps the name and the second is left out, none of its registrations kept."""
    _, _, second_registers, name, key = KINDS[kind]
    registry = _two_plugins(kind, second_registers)
    first, second = Origin("first", "first 1", "first = first"), Origin("second", "second 2", "second = second")
    assert registry.failures == {
        "second": f"registration failed: ValueError: {name} is registered by {first} and by {second}; "
        "rename one of them"
    }
    assert registry.conflicts == {key: [first, second]}
    owner = _owner(registry, kind)
    assert owner is None or owner.plugin == "first"
    assert set(registry.capabilities.values()) <= {"makes gadgets", "makes widgets"} and not registry.protocols
    assert set(registry.artifacts.values()) <= {Gadget} and set(registry.settings.values()) <= {GadgetSettings}


def test_broken_plugins_are_left_out_with_a_reason(caplog: pytest.LogCaptureFixture) -> None:
    def explode(registry):  # noqa: ANN001
        registry.add_implementation("depth", "half_done", object)
        raise RuntimeError("boom")

    def declare_gadgets(registry):  # noqa: ANN001
        registry.add_capability("gadgets", "makes gadgets", protocol=Protocol)

    def explode_later(registry):  # noqa: ANN001
        raise RuntimeError("late")

    broken = [
        (plugin(register_implementations=explode), Origin("exploding", "x 1", "exploding = x")),
        (plugin(register_everything=lambda: None), Origin("misspelt", "y 1", "misspelt = y")),
        (plugin(register_stages=lambda registri: None), Origin("mistyped", "z 1", "mistyped = z")),
        (
            plugin(register_capabilities=declare_gadgets, register_stages=explode_later),
            Origin("half_gone", "w 1", "half_gone = w"),
        ),
    ]
    system = load_plugins(extra=broken)
    assert "registration failed: RuntimeError: boom" in system.registry.failures["exploding"]
    assert "unknown hook(s) register_everything" in system.registry.failures["misspelt"]
    assert "could not be registered" in system.registry.failures["mistyped"]  # a hook argument pluggy refuses
    assert ("depth", "half_done") not in system.registry.implementations  # rolled back
    assert "registration failed: RuntimeError: late" in system.registry.failures["half_gone"]
    assert "gadgets" not in system.registry.capabilities and "gadgets" not in system.registry.protocols  # every phase
    assert set(system.registry.implementations) >= BUILTIN_IMPLEMENTATIONS
    assert any("exploding" in r.getMessage() for r in caplog.records)
    with pytest.raises(PsdrRoomError, match="left out: exploding: registration failed"):
        system.registry.implementation("depth", "half_done")


@pytest.fixture(scope="module")
def third_party(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The example third-party plugin (examples/third_party_plugin) installed with pip into a target dir."""
    source = tmp_path_factory.mktemp("src") / "plugin"
    shutil.copytree(REPO / "examples" / "third_party_plugin", source)
    target = tmp_path_factory.mktemp("site")
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "install",
            "-q",
            "--no-deps",
            "--no-build-isolation",
            "--target",
            str(target),
            str(source),
        ],
        check=True,
        capture_output=True,
    )
    return target


def _env(cli_env: dict[str, str], site: Path) -> dict[str, str]:
    return {**cli_env, "PYTHONPATH": str(site)}


def test_third_party_plugin_is_listed(third_party: Path, cli_env: dict[str, str]) -> None:
    out = subprocess.run(
        [shutil.which("psdr-room-plugins") or "psdr-room-plugins"],
        env=_env(cli_env, third_party),
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    line = next(row for row in out.splitlines() if row.startswith("fov") and " exif " in row)
    assert "plugin 'exif' (exif = psdr_room_exif, from psdr-room-exif 0.1.0)" in line


def test_third_party_plugin_selected_from_the_cli(third_party: Path, cli_env: dict[str, str], tmp_path: Path) -> None:
    photo_dir = tmp_path / "photo"
    shutil.copytree(EXAMPLE.parent, photo_dir)
    photo = photo_dir / EXAMPLE.name
    with PIL.Image.open(EXAMPLE) as pil:  # a 35 mm-equivalent focal length of 28 mm in the EXIF
        exif = pil.getexif()
        exif.get_ifd(0x8769)[0xA405] = 28
        pil.save(photo, exif=exif)
    result = subprocess.run(
        [
            shutil.which("psdr-room") or "psdr-room",
            f"image={photo}",
            "fov=exif",
            "run.until=estimate_fov",
            f"hydra.run.dir={tmp_path / 'run'}",
        ],
        env=_env(cli_env, third_party),
        capture_output=True,
        text=True,
    )
    assert result.returncode == 0, result.stderr
    metrics = json.loads((tmp_path / "run" / "metrics.json").read_text())
    assert metrics["implementations"]["fov"]["name"] == "exif"
    assert metrics["camera"]["method"] == "exif"
    # 28 mm on a 43.27 mm diagonal, 4:3 frame: vertical FoV = 2 atan(0.5 * 0.6 * 43.27 / 28)
    assert metrics["vfov_deg"] == pytest.approx(49.7, abs=0.2)


def test_third_party_settings_are_checked(third_party: Path, cli_env: dict[str, str], tmp_path: Path) -> None:
    """The plugin's declared schema (ExifSettings) refuses an impossible value before any stage runs."""
    result = subprocess.run(
        [
            shutil.which("psdr-room") or "psdr-room",
            f"image={EXAMPLE}",
            "fov=exif",
            "fov.exif.fallback_vfov_deg=200",
            f"hydra.run.dir={tmp_path / 'run'}",
            f"cache_dir={tmp_path / 'cache'}",
        ],
        env=_env(cli_env, third_party),
        capture_output=True,
        text=True,
    )
    assert result.returncode != 0
    assert result.stderr.strip().splitlines() == [
        "psdr-room: error: fov.exif.fallback_vfov_deg=200.0 is out of range; allowed: a number > 0 and < 180"
    ]
    assert not (tmp_path / "cache").exists() and not (tmp_path / "run" / "metrics.json").exists()


def test_every_builtin_implementation_class_has_its_capabilitys_methods() -> None:
    """The engine checks an implementation against its capability's protocol when it constructs one (test_dag);
    the built-in classes pass that check without being constructed (factory functions are checked when run)."""
    registry = load_plugins().registry
    assert set(registry.protocols) == set(registry.capabilities)
    classes = [(key, impl.factory) for key, impl in registry.implementations.items() if isinstance(impl.factory, type)]
    assert len(classes) >= 15
    missing = {
        key: [
            m for m in dir(registry.protocols[key[0]]) if not m.startswith("_") and not callable(getattr(cls, m, None))
        ]
        for key, cls in classes
    }
    assert not {key: names for key, names in missing.items() if names}


def test_help_lists_plugins_options_and_imports_no_heavy_library(third_party: Path, cli_env: dict[str, str]) -> None:
    """``psdr-room --help`` reads the registry and the config folders (a third-party plugin's included); stages and
    the torch- and Mitsuba-based implementations are registered by reference, so it imports none of them."""
    result = subprocess.run(
        [shutil.which("psdr-room") or "psdr-room", "--help"],
        env={**_env(cli_env, third_party), "PYTHONPROFILEIMPORTTIME": "1"},
        capture_output=True,
        text=True,
        check=True,
    )
    rows = {line.split()[0]: line.split(maxsplit=1)[1] for line in result.stdout.splitlines() if line.startswith("  ")}
    assert rows["fov"] == "exif, fixed, vanishing_points*" and rows["renderer"] == "mitsuba*"
    assert rows["+preset"] == "preview" and "load_image, estimate_fov, detect" in result.stdout
    imported = {
        line.rsplit("|", 1)[1].strip() for line in result.stderr.splitlines() if line.startswith("import time:")
    }
    assert "psdr_room_core" in imported and not {"torch", "mitsuba", "drjit", "scipy"} & imported
