"""Typed settings (psdr_room_core.engine.settings): every built-in stage and implementation declares a schema, the
shipped config fits every one of them, and a bad value or key is refused in one line naming it."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import pytest

from psdr_room_core.engine.cli import compose_config
from psdr_room_core.engine.dag import Pipeline
from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.engine.plugins import plugin_system
from psdr_room_core.engine.run import resolve_config
from psdr_room_core.engine.settings import check_config, check_settings, setting

CONF = Path(__file__).resolve().parents[1] / "conf"
GROUPS = (
    "fov",
    "detector",
    "segmentation",
    "depth",
    "retrieval",
    "renderer",
    "optimizer",
    "material_graph",
    "texture",
    "denoiser",
)


def _check(overrides: list[str]) -> None:
    system = plugin_system()
    data = resolve_config(compose_config(["image=photo.jpg", *overrides], system))
    check_config(data, Pipeline.from_config(data).nodes, system.registry)


def test_every_builtin_declares_a_schema() -> None:
    registry = plugin_system().registry
    assert not [name for name, stage in registry.stages.items() if stage.params is None]
    assert not [key for key, impl in registry.implementations.items() if impl.params is None]


@pytest.mark.parametrize("option", sorted(f"{g}={p.stem}" for g in GROUPS for p in (CONF / g).glob("*.yaml")))
def test_shipped_config_fits_the_schemas(option: str) -> None:
    _check([option])


@pytest.mark.parametrize(
    ("override", "message"),
    [
        (
            "room_fit.iterations=abc",
            "room_fit.iterations=abc is invalid: Value 'abc' of type 'str' could not be converted to Integer; allowed: an integer >= 1",
        ),
        ("room_fit.iterations=-3", "room_fit.iterations=-3 is out of range; allowed: an integer >= 1"),
        (
            "fit_objects.learning_rates.yaw=-1",
            "fit_objects.learning_rates.yaw=-1.0 is out of range; allowed: a number >= 0",
        ),
        ("load_image.max_side=0", "load_image.max_side=0 is out of range; allowed: an integer >= 64"),
        (
            "+room_init.ransac_iters=5",
            "room_init.ransac_iters is not a setting of room_init (did you mean ransac_iterations?); known: ransac_threshold,",
        ),
        (
            "+fit_appearance.weights.colur=1",
            "fit_appearance.weights.colur is not a setting of fit_appearance.weights (did you mean colour?); known: image, colour, texture, paint",
        ),
        (
            "renderer.mitsuba.rgb_guiding=fast",
            "renderer.mitsuba.rgb_guiding=fast is not one of the choices; allowed: one of none, grid, octree",
        ),
        (
            "init_lights.ceiling_grid=[3,3,3]",
            "init_lights.ceiling_grid=[3, 3, 3] is invalid; allowed: a list of integers >= 1, 2 of them",
        ),
        (
            "segmentation.layout.discovery.min_visible=1.5",
            "segmentation.layout.discovery.min_visible=1.5 is out of range; allowed: a number >= 0 and <= 1",
        ),
        (
            "detector.nanodet_onnx.flip=maybe",
            "detector.nanodet_onnx.flip=maybe is invalid: Value 'maybe' is not a valid bool",
        ),
        (
            "fit_appearance._uses_.texture.size=8",
            "fit_appearance._uses_.texture.size=8 is out of range; allowed: null or an integer >= 16",
        ),
        (
            "retrieval.auto.order=[]",
            "retrieval.auto.order=[] is invalid; allowed: a non-empty list of retrieval implementation names",
        ),
    ],
)
def test_bad_setting_is_refused_in_one_line(override: str, message: str) -> None:
    with pytest.raises(PsdrRoomError) as caught:
        _check([override])
    assert str(caught.value).startswith(message), str(caught.value)
    assert "\n" not in str(caught.value)


@dataclass
class Inner:
    size: int | None = setting(ge=8)


@dataclass
class Outer:
    ratio: float = setting(gt=0, lt=1)
    word: str = setting("a", choices=("a", "b"))
    inner: Inner | None = setting()


def test_schema_rules() -> None:
    check_settings(Outer, {"ratio": 0.5, "inner": {"size": None}}, "x")  # defaults and nulls are fine
    check_settings(Outer, {"ratio": 0.5, "inner": None}, "x")
    for values, message in [
        ({"ratio": 1}, "x.ratio=1.0 is out of range; allowed: a number > 0 and < 1"),
        ({"ratio": 0.5, "inner": {"size": 4}}, "x.inner.size=4 is out of range"),
        ({"ratio": 0.5, "word": "c"}, "x.word=c is not one of the choices; allowed: one of a, b"),
        ({}, "x.ratio has no value"),
    ]:
        with pytest.raises(PsdrRoomError, match="^" + message.replace(".", r"\.").replace("+", r"\+")):
            check_settings(Outer, {"inner": None, **values}, "x")


def test_a_stage_reads_its_settings_as_the_schema_it_declared() -> None:
    """StageContext.settings: the checked values as the schema's object, nested schemas included; the runtime
    knobs of the library (view search, support rules, settling) are the schemas themselves, not twins of them."""
    from psdr_room_core.engine.dag import StageContext
    from psdr_room_core.method.physical import PhysicalParams
    from psdr_room_core.method.stages.settings import PlaceObjects
    from psdr_room_core.method.view_search import SearchParams

    system = plugin_system()
    data = resolve_config(compose_config(["image=photo.jpg", "place_objects.search.n_yaw=8"], system))
    node = next(n for n in Pipeline.from_config(data).nodes if n.name == "place_objects")
    assert system.registry.stages[node.function].params is PlaceObjects
    ctx = StageContext(
        stage="place_objects", params=dict(node.params), seed=0, photo=Path("photo.jpg"), implementations={}
    )
    settings = ctx.settings(PlaceObjects)
    assert isinstance(settings.search, SearchParams) and isinstance(settings.physical, PhysicalParams)
    assert settings.search.n_yaw == 8 and settings.search.turns == [90.0, 180.0, 270.0]
    assert settings.support.floor_only[0] == "bed" and settings.prune.min_iou == 0.3
