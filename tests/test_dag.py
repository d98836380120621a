"""The DAG runner and its cache: keys invalidate exactly the stages that changed, failures leave nothing."""

from __future__ import annotations

import copy
import gc
import sys
import weakref
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest

import toy_plugin
from psdr_room_core.engine.cache import Store
from psdr_room_core.engine.context import StageContext
from psdr_room_core.engine.errors import PsdrRoomError
from psdr_room_core.engine.graph import Pipeline, check_stage_inputs
from psdr_room_core.engine.hookspecs import hookimpl
from psdr_room_core.engine.plugins import load_plugins
from psdr_room_core.engine.records import RunRecord, StageRecord
from psdr_room_core.engine.registry import Origin, Registry
from psdr_room_core.engine.runner import Runner
from psdr_room_core.engine.settings import setting

TOY = Origin("toy", "tests", "toy = toy_plugin")

BASE: dict[str, Any] = {
    "seed": 0,
    "scaler": {"impl": "toy", "toy": {"factor": 2.0}},
    "a": {"_stage_": "toy_source", "_inputs_": {}, "_outputs_": ["a"], "start": 1.0},
    "b": {"_stage_": "toy_scale", "_inputs_": {"x": "a"}, "_outputs_": ["b"]},
    "c": {"_stage_": "toy_add", "_inputs_": {"x": "a", "y": "b"}, "_outputs_": {"total": "c"}},
    "d": {"_stage_": "toy_source", "_inputs_": {}, "_outputs_": ["d"], "start": 5.0, "use_photo": True},
}


class Events:
    """Records run-event hooks: each stage hook's record, and what it held when the hook was called."""

    def __init__(self) -> None:
        self.errors: list[str] = []
        self.calls: list[tuple[str, StageRecord, dict[str, Any]]] = []

    def _called(self, hook: str, record: StageRecord) -> None:
        self.calls.append((hook, record, dict(vars(record))))

    @hookimpl
    def before_stage(self, record: StageRecord, inputs: dict) -> None:
        self._called("before", record)

    @hookimpl
    def after_stage(self, record: StageRecord, outputs: dict) -> None:
        self._called("after", record)

    @hookimpl
    def on_stage_error(self, record: StageRecord, error: BaseException) -> None:
        self._called("error", record)
        self.errors.append(record.name)


class DeprecatedEvents:
    """Stage hooks in the deprecated form: the stage's name and key instead of its record."""

    def __init__(self) -> None:
        self.calls: list[tuple[str, str, str]] = []

    @hookimpl
    def before_stage(self, stage: str, key: str, inputs: dict) -> None:
        self.calls.append(("before", stage, key))

    @hookimpl
    def on_stage_error(self, stage: str, key: str, error: BaseException) -> None:
        self.calls.append(("error", stage, key))


@pytest.fixture
def photo(tmp_path: Path) -> Path:
    path = tmp_path / "photo.bin"
    path.write_bytes(b"x" * 10)
    return path


def run(
    cfg: dict,
    photo: Path,
    store: Store,
    tmp_path: Path,
    mode: str = "readwrite",
    events: object | None = None,
    **select: str,
) -> RunRecord:
    extra = [(toy_plugin, TOY)] + ([(events, Origin("events", "tests", "events"))] if events else [])
    plugins = load_plugins(extra=extra)
    pipeline = Pipeline.from_config(cfg)
    runner = Runner(plugins, cfg, photo, store, Store(tmp_path / "scratch"), mode)
    return runner.run(pipeline.select(**select))


def recomputed(record: RunRecord) -> set[str]:
    return {r.name for r in record.stages if not r.cached}


def test_rerun_is_fully_cached_and_same_digests(tmp_path: Path, photo: Path) -> None:
    store = Store(tmp_path / "cache")
    first = run(BASE, photo, store, tmp_path)
    assert recomputed(first) == {"a", "b", "c", "d"}
    assert first.artifacts["c"].value == 1.0 + 2.0
    second = run(BASE, photo, store, tmp_path)
    assert recomputed(second) == set()
    assert second.digests == first.digests


@pytest.mark.parametrize(
    ("change", "expected"),
    [
        (lambda c: c["a"].update(start=3.0), {"a", "b", "c"}),  # a stage's config
        (lambda c: c["scaler"]["toy"].update(factor=3.0), {"b", "c"}),  # an implementation's params
        (lambda c: c.update(seed=1), {"a", "b", "c", "d"}),  # the seed is in every key
        (lambda c: c["b"].update(note="x"), {"b"}),  # b's output is unchanged: c stays cached
    ],
)
def test_config_change_invalidates_exactly_dependents(tmp_path: Path, photo: Path, change: Any, expected: set) -> None:
    store = Store(tmp_path / "cache")
    run(BASE, photo, store, tmp_path)
    cfg = copy.deepcopy(BASE)
    change(cfg)
    assert recomputed(run(cfg, photo, store, tmp_path)) == expected


def test_input_file_change_invalidates_the_stage_reading_it(tmp_path: Path, photo: Path) -> None:
    store = Store(tmp_path / "cache")
    run(BASE, photo, store, tmp_path)
    photo.write_bytes(b"y" * 10)  # same size: only the content digest differs
    record = run(BASE, photo, store, tmp_path)
    # a and d read the photo; a's output is unchanged (it ignores the photo) so b and c stay cached
    assert recomputed(record) == {"a", "d"}


def test_implementation_version_change_invalidates_its_users(tmp_path: Path, photo: Path, monkeypatch) -> None:
    store = Store(tmp_path / "cache")
    run(BASE, photo, store, tmp_path)
    monkeypatch.setitem(toy_plugin.VERSION, "toy", "2")
    # b reruns; its output is the same number, so c (keyed by b's content digest) stays cached
    assert recomputed(run(BASE, photo, store, tmp_path)) == {"b"}


def test_a_stage_uses_its_own_settings_of_a_capability(tmp_path: Path, photo: Path) -> None:
    store = Store(tmp_path / "cache")
    run(BASE, photo, store, tmp_path)
    cfg = copy.deepcopy(BASE)
    cfg["b"]["_uses_"] = {"scaler": {"factor": 3.0}}  # b alone multiplies by 3; the group still says 2
    record = run(cfg, photo, store, tmp_path)
    assert recomputed(record) == {"b", "c"}  # b's key holds its settings; c reads b's new output
    assert record.artifacts["b"].value == 3.0 and record.artifacts["c"].value == 1.0 + 3.0
    assert cfg["scaler"]["toy"]["factor"] == 2.0
    cfg["a"]["_uses_"] = {"scaler": {"factor": 3.0}}
    with pytest.raises(PsdrRoomError, match="stage 'a': _uses_ names scaler, which the stage does not use"):
        run(cfg, photo, store, tmp_path)


class CycleLeaver:
    """A stage that leaves its scene in a reference cycle, and one that checks the cycle is gone."""

    def __init__(self) -> None:
        self.left: list[weakref.ref] = []
        self.alive_after: list[bool] = []

    def leave(self, ctx: StageContext, x: toy_plugin.Number) -> toy_plugin.Number:
        scene = Scene()
        scene.myself = scene
        self.left.append(weakref.ref(scene))
        return toy_plugin.Number(x.value)

    def check(self, ctx: StageContext, x: toy_plugin.Number) -> toy_plugin.Number:
        self.alive_after.append(self.left[-1]() is not None)
        return toy_plugin.Number(x.value)

    @hookimpl
    def register_stages(self, registry: Registry) -> None:
        registry.add_stage("leave", self.leave)
        registry.add_stage("check", self.check)


class Scene:
    myself: object


def test_a_stage_leaves_no_reference_cycles_to_the_next(tmp_path: Path, photo: Path) -> None:
    leaver = CycleLeaver()
    cfg = {
        **copy.deepcopy(BASE),
        "e": {"_stage_": "leave", "_inputs_": {"x": "a"}, "_outputs_": ["e"]},
        "f": {"_stage_": "check", "_inputs_": {"x": "e"}, "_outputs_": ["f"]},
    }
    plugins = load_plugins(extra=[(toy_plugin, TOY), (leaver, Origin("leaver", "tests", "leaver"))])
    enabled = gc.isenabled()
    gc.disable()  # only the engine's collection can free the cycle
    try:
        Runner(plugins, cfg, photo, Store(tmp_path / "cache"), Store(tmp_path / "scratch")).run(
            Pipeline.from_config(cfg).select()
        )
    finally:
        if enabled:
            gc.enable()
    assert leaver.left and leaver.alive_after == [False]


@pytest.mark.parametrize("damage", ["edit", "delete", "manifest"])
def test_a_damaged_cache_entry_is_moved_aside_and_recomputed(
    tmp_path: Path, photo: Path, damage: str, caplog: pytest.LogCaptureFixture
) -> None:
    store = Store(tmp_path / "cache")
    first = run(BASE, photo, store, tmp_path)
    entry = store.lookup(next(r.key for r in first.stages if r.name == "b"))
    assert entry is not None
    target = next(p for p in (entry.path / "b").rglob("*") if p.is_file())
    if damage == "edit":  # same size, other bytes
        data = bytearray(target.read_bytes())
        data[0] ^= 0xFF
        target.write_bytes(bytes(data))
    elif damage == "delete":
        target.unlink()
    else:
        (entry.path / "manifest.json").write_text("{ not json")
    with caplog.at_level("WARNING", logger="psdr_room"):
        second = run(BASE, photo, store, tmp_path)
    assert recomputed(second) == {"b"}  # c is keyed by b's digest, which is the same again
    assert second.digests == first.digests
    assert [r.getMessage() for r in caplog.records if "damaged" in r.getMessage()][0].count("\n") == 0
    quarantined = list((store.root / "quarantine").iterdir())
    assert len(quarantined) == 1 and quarantined[0].name.startswith(entry.key)
    assert recomputed(run(BASE, photo, store, tmp_path)) == set()


def test_cache_tool_reports_verifies_and_prunes(tmp_path: Path, photo: Path, capsys: pytest.CaptureFixture) -> None:
    from psdr_room_core.engine.cache_cli import main as cache_main

    store = Store(tmp_path / "cache")
    run(BASE, photo, store, tmp_path)
    root = str(store.root)
    assert cache_main(["du", "--cache-dir", root]) == 0
    table = capsys.readouterr().out
    assert "total" in table and " 4 " in table.splitlines()[-2]
    assert cache_main(["verify", "--cache-dir", root]) == 0
    victim = next(store.entries())
    (victim.path / "manifest.json").write_text("[]")
    assert cache_main(["verify", "--cache-dir", root]) == 1
    out = capsys.readouterr().out
    assert "4 entries checked in" in out and "1 damaged" in out
    assert cache_main(["prune", "--cache-dir", root, "--max-size", "0"]) == 0
    assert "removed 3 entries" in capsys.readouterr().out
    assert not list(store.entries()) and not (store.root / "quarantine").exists()
    assert cache_main(["du", "--cache-dir", str(tmp_path / "nowhere")]) == 2
    assert "not a psdr-room cache" in capsys.readouterr().err


def test_failing_stage_leaves_no_entry(tmp_path: Path, photo: Path) -> None:
    store = Store(tmp_path / "cache")
    cfg = copy.deepcopy(BASE)
    cfg["b"]["fail"] = True
    events = Events()
    with pytest.raises(RuntimeError, match="toy failure"):
        run(cfg, photo, store, tmp_path, events=events)
    assert events.errors == ["b"]
    entries = {p.name for p in (store.root / "entries").glob("*/*")}
    assert len(entries) == 1  # a was committed; b failed; c and d (after b in config order) never ran
    assert not list((store.root / "tmp").iterdir())
    # the fixed config resumes after the committed stages
    cfg["b"]["fail"] = False
    assert recomputed(run(cfg, photo, store, tmp_path)) == {"b", "c", "d"}


def test_stage_hooks_get_one_record_per_stage_filled_in_as_it_runs(tmp_path: Path, photo: Path) -> None:
    """``before_stage`` gets the stage's record with its name and cache key; ``after_stage`` or ``on_stage_error``
    gets that same object, the first with the stage's results filled in."""
    store = Store(tmp_path / "cache")
    events = Events()
    record = run(BASE, photo, store, tmp_path, events=events)
    assert [(hook, r.name) for hook, r, _ in events.calls] == [
        (hook, name) for name in "abcd" for hook in ("before", "after")
    ]
    for (_, before, held), (_, after, _), done in zip(events.calls[::2], events.calls[1::2], record.stages):
        assert before is after is done
        assert held["name"] == done.name and held["key"] == done.key and held["function"] == done.function
        assert held["implementations"] == done.implementations and not held["cached"] and held["outputs"] == {}
        assert done.outputs == {a: record.digests[a] for a in done.outputs} and done.seconds > 0
    cfg = copy.deepcopy(BASE)
    cfg["b"]["fail"] = True
    events = Events()
    with pytest.raises(RuntimeError, match="toy failure"):
        run(cfg, photo, store, tmp_path, events=events)
    assert [(hook, r.name) for hook, r, _ in events.calls] == [("after", "a"), ("before", "b"), ("error", "b")]
    assert events.calls[1][1] is events.calls[2][1]


def test_stage_hooks_taking_stage_and_key_still_work_and_are_deprecated(tmp_path: Path, photo: Path) -> None:
    """A plugin written for ``before_stage(stage, key, inputs)`` and ``on_stage_error(stage, key, error)`` gets
    those arguments, and a DeprecationWarning when it is registered."""
    events = DeprecatedEvents()
    cfg = copy.deepcopy(BASE)
    cfg["b"]["fail"] = True
    with pytest.warns(DeprecationWarning) as warned, pytest.raises(RuntimeError, match="toy failure"):
        run(cfg, photo, Store(tmp_path / "cache"), tmp_path, events=events)
    assert sorted(str(w.message).split(" is deprecated")[0] for w in warned) == [
        "before_stage: the argument 'key'",
        "before_stage: the argument 'stage'",
        "on_stage_error: the argument 'key'",
        "on_stage_error: the argument 'stage'",
    ]
    assert [(hook, stage) for hook, stage, _ in events.calls] == [("before", "a"), ("before", "b"), ("error", "b")]
    assert events.calls[1][2] == events.calls[2][2] and len(events.calls[1][2]) == 64


def test_selection_until_from_only(tmp_path: Path, photo: Path) -> None:
    store = Store(tmp_path / "cache")
    assert [r.name for r in run(BASE, photo, store, tmp_path, until="b").stages] == ["a", "b"]
    record = run(BASE, photo, store, tmp_path, start="b")
    assert [r.name for r in record.stages] == ["a", "b", "c"] and recomputed(record) == {"b", "c"}
    record = run(BASE, photo, store, tmp_path, only="b")
    assert [r.name for r in record.stages] == ["a", "b"] and recomputed(record) == {"b"}


def test_a_forced_recompute_replaces_the_entry_it_recomputed(tmp_path: Path, photo: Path, monkeypatch) -> None:
    """``run.only`` after a code change that kept the key (or with a nondeterministic stage): the run, the
    cache and the next run all get the new result, not the entry it recomputed."""
    store = Store(tmp_path / "cache")
    before = run(BASE, photo, store, tmp_path).digests["b"]
    monkeypatch.setattr(toy_plugin.Multiplier, "apply", lambda self, value, photo: value * 3.0)
    forced = run(BASE, photo, store, tmp_path, only="b")
    assert recomputed(forced) == {"b"} and forced.digests["b"] != before
    assert forced.artifacts["b"].value == 3.0
    again = run(BASE, photo, store, tmp_path, until="b")
    assert recomputed(again) == set() and again.digests["b"] == forced.digests["b"]
    assert not list((tmp_path / "cache" / "tmp").iterdir())


def test_cache_modes(tmp_path: Path, photo: Path) -> None:
    store = Store(tmp_path / "cache")
    run(BASE, photo, store, tmp_path, mode="off")
    assert not list((store.root / "entries").iterdir())
    run(BASE, photo, store, tmp_path)
    before = sorted((store.root / "entries").glob("*/*"))
    cfg = copy.deepcopy(BASE)
    cfg["d"]["start"] = 6.0
    record = run(cfg, photo, store, tmp_path, mode="read")
    assert recomputed(record) == {"d"}
    assert sorted((store.root / "entries").glob("*/*")) == before  # read mode commits nothing


def test_pipeline_validation() -> None:
    cfg = copy.deepcopy(BASE)
    del cfg["a"]
    with pytest.raises(PsdrRoomError, match="needs artifact 'a' but no stage produces it"):
        Pipeline.from_config(cfg)
    cfg = copy.deepcopy(BASE)
    cfg["a2"] = dict(cfg["a"])
    with pytest.raises(PsdrRoomError, match="produced by both stages 'a' and 'a2'"):
        Pipeline.from_config(cfg)
    cfg = copy.deepcopy(BASE)
    cfg["a"]["_inputs_"] = {"x": "c"}
    with pytest.raises(PsdrRoomError, match="form a cycle"):
        Pipeline.from_config(cfg)


def test_a_stage_input_its_function_does_not_take_fails_when_the_pipeline_is_built() -> None:
    """kedro's check, before any stage runs: the input's name, what the function expects and what was found."""
    registry = load_plugins(extra=[(toy_plugin, TOY)]).registry
    check_stage_inputs(Pipeline.from_config(BASE).nodes, registry)
    cfg = copy.deepcopy(BASE)
    cfg["c"]["_inputs_"] = {"x": "a", "why": "b"}
    with pytest.raises(PsdrRoomError) as wrong:
        check_stage_inputs(Pipeline.from_config(cfg).nodes, registry)
    assert str(wrong.value) == (
        "stage 'c': input 'why' is not a parameter of its function; expected x, y (stage "
        "function toy_add), found x, why; fix c._inputs_"
    )
    cfg["c"]["_inputs_"] = {"x": "a"}
    with pytest.raises(PsdrRoomError, match="stage 'c': no input for parameter 'y'; expected x, y .* found x; add it"):
        check_stage_inputs(Pipeline.from_config(cfg).nodes, registry)


def test_injected_artifact_replaces_its_producer(tmp_path: Path, photo: Path) -> None:
    edited = tmp_path / "edited_a"
    edited.mkdir()
    toy_plugin.Number(10.0).save(edited)
    cfg = copy.deepcopy(BASE)  # stage a, which computes a, stays in the config: what was given replaces it
    plugins = load_plugins(extra=[(toy_plugin, TOY)])
    pipeline = Pipeline.from_config(cfg, provided=["a"])
    assert "a" not in [node.name for node in pipeline.nodes]
    runner = Runner(plugins, cfg, photo, Store(tmp_path / "cache"), Store(tmp_path / "scratch"), injected={"a": edited})
    record = runner.run(pipeline.select())
    assert "a" not in [s.name for s in record.stages]
    assert record.artifacts["c"].value == 10.0 + 20.0


def test_an_injected_artifact_whose_stage_computes_more_is_refused_in_one_line() -> None:
    cfg = copy.deepcopy(BASE)
    cfg["a"]["_outputs_"] = {"value": "a", "extra": "a_extra"}
    with pytest.raises(PsdrRoomError, match=r"inject.a is given but stage 'a' also computes a_extra; give those too"):
        Pipeline.from_config(cfg, provided=["a"])


AUTO = {
    **BASE,
    "scaler": {"impl": "auto", "auto": {"order": ["toy_sidecar", "toy"]}, "toy_sidecar": {}, "toy": {"factor": 2.0}},
}


def test_auto_selects_the_first_usable_implementation_and_keys_the_choice(tmp_path: Path, photo: Path) -> None:
    store = Store(tmp_path / "cache")
    first = run(AUTO, photo, store, tmp_path)
    assert first.implementations["scaler"]["name"] == "toy"
    assert "not toy_sidecar: no .factor file" in first.implementations["scaler"]["selected_by"]
    assert first.artifacts["b"].value == 2.0
    photo.with_suffix(".factor").write_text("3")  # now the sidecar implementation is usable: b is recomputed
    second = run(AUTO, photo, store, tmp_path)
    assert second.implementations["scaler"]["name"] == "toy_sidecar" and second.artifacts["b"].value == 3.0
    assert recomputed(second) == {"b", "c"}
    assert recomputed(run(AUTO, photo, store, tmp_path)) == set()


def test_auto_with_nothing_usable_names_the_candidates(tmp_path: Path, photo: Path) -> None:
    cfg = {**AUTO, "scaler": {**AUTO["scaler"], "auto": {"order": ["toy_sidecar"]}}}
    with pytest.raises(PsdrRoomError, match="none of toy_sidecar is usable.*no .factor file"):
        run(cfg, photo, Store(tmp_path / "cache"), tmp_path)


def test_an_implementation_missing_a_method_of_its_capability_is_refused_in_one_line(
    tmp_path: Path, photo: Path
) -> None:
    """The capability's protocol is checked when the engine constructs an implementation, before its stage runs."""

    class Adder:  # a scaler without apply
        def add(self, value: float, photo: Path) -> float:
            return value + 1.0

    def register(registry: Any) -> None:
        registry.add_implementation("scaler", "adder", Adder)

    cfg = copy.deepcopy(BASE)
    cfg["scaler"]["impl"] = "adder"
    plugins = load_plugins(
        extra=[
            (toy_plugin, TOY),
            (SimpleNamespace(register_implementations=hookimpl(register)), Origin("adder", "tests", "adder")),
        ]
    )
    runner = Runner(plugins, cfg, photo, Store(tmp_path / "cache"), Store(tmp_path / "scratch"), "readwrite")
    scaled = toy_plugin.CALLS["b"]
    with pytest.raises(PsdrRoomError) as caught:
        runner.run(Pipeline.from_config(cfg).select())
    assert str(caught.value) == (
        "scaler.adder (Adder) is not a scaler implementation: it has no apply (the toy_plugin.Scaler protocol)"
    )
    assert toy_plugin.CALLS["b"] == scaled  # the stage that uses it never ran
    ctx = StageContext(stage="b", params={}, seed=0, photo=photo, implementations={"scaler": Adder()})
    with pytest.raises(PsdrRoomError, match="^stage 'b' wants its scaler to be a Scaler; Adder is not$"):
        ctx.impl("scaler", toy_plugin.Scaler)


LAZY_MODULE = '''
import toy_plugin


def scale(ctx, x, by=None):
    """Ten times x, with the scaler's say."""
    return toy_plugin.Number(ctx.impl("scaler").apply(x.value, ctx.photo) * 10)


class Tripler:
    def __init__(self, factor=3.0):
        self.factor = factor

    def apply(self, value, photo):
        return value * self.factor


class Reader(Tripler):
    def external_files(self, photo):
        return []
'''


def test_references_load_only_when_a_stage_computes(tmp_path: Path, photo: Path, monkeypatch) -> None:
    """A stage and an implementation registered by ``"module:attribute"``: the input check reads the function from
    its source, a computing stage imports both, a cached run imports neither; a ``reads_files=False``
    implementation that has ``external_files`` after all is refused."""
    (tmp_path / "lazy_toy.py").write_text(LAZY_MODULE)
    monkeypatch.syspath_prepend(str(tmp_path))

    def register_implementations(registry: Any) -> None:
        registry.add_implementation("scaler", "lazy", "lazy_toy:Tripler", reads_files=False)
        registry.add_implementation("scaler", "liar", "lazy_toy:Reader", reads_files=False)

    def register_stages(registry: Any) -> None:
        registry.add_stage("lazy_scale", "lazy_toy:scale", uses=["scaler"])

    lazy = SimpleNamespace(
        register_implementations=hookimpl(register_implementations), register_stages=hookimpl(register_stages)
    )
    plugins = load_plugins(extra=[(toy_plugin, TOY), (lazy, Origin("lazy", "tests", "lazy = lazy_toy"))])
    cfg = copy.deepcopy(BASE)
    cfg["scaler"] = {"impl": "lazy", "lazy": {}, "liar": {}}
    cfg["b"]["_stage_"] = "lazy_scale"
    store = Store(tmp_path / "cache")

    def run_lazy(cfg: dict) -> RunRecord:
        pipeline = Pipeline.from_config(cfg)
        check_stage_inputs(pipeline.nodes, plugins.registry)
        return Runner(plugins, cfg, photo, store, Store(tmp_path / "scratch"), "readwrite").run(pipeline.select())

    assert plugins.registry.stage("lazy_scale").description == "Ten times x, with the scaler's say."
    wrong = copy.deepcopy(cfg)
    wrong["b"]["_inputs_"] = {"y": "a"}
    with pytest.raises(PsdrRoomError, match="stage 'b': input 'y' is not a parameter of its function; expected x, by"):
        check_stage_inputs(Pipeline.from_config(wrong).nodes, plugins.registry)
    assert "lazy_toy" not in sys.modules  # read from the source
    first = run_lazy(cfg)
    assert first.artifacts["b"].value == 1.0 * 3.0 * 10 and "lazy_toy" in sys.modules
    monkeypatch.delitem(sys.modules, "lazy_toy")
    assert recomputed(run_lazy(cfg)) == set() and "lazy_toy" not in sys.modules
    cfg["scaler"]["impl"] = "liar"
    with pytest.raises(PsdrRoomError, match=r"scaler.liar .* has external_files but was registered with reads_files"):
        run_lazy(cfg)


def test_a_run_hands_its_artifacts_to_hooks_by_type(tmp_path: Path, photo: Path) -> None:
    """``RunRecord.artifact(names, kind)``: the first of the names the run has, if it is a ``kind``."""
    record = run(BASE, photo, Store(tmp_path / "cache"), tmp_path)
    assert record.artifact("c", toy_plugin.Number) is record.artifacts["c"]
    assert record.artifact(("missing", "b", "c"), toy_plugin.Number) is record.artifacts["b"]
    assert record.artifact("missing", toy_plugin.Number) is None and record.artifact("c", Events) is None


@dataclass
class Shift:
    by: float = setting(ge=0)


@dataclass
class ShiftingSettings:
    factor: float = setting(gt=0)
    shift: Shift = setting()


class Shifting:
    """Multiplies by ``factor``, then adds ``shift.by``; records what its factory was given."""

    made: list[tuple[Any, Any]] = []

    def __init__(self, factor: float = 5.0, shift: Shift | None = None) -> None:
        Shifting.made.append((factor, shift))
        self.factor, self.by = factor, shift.by if shift is not None else 0.0

    def apply(self, value: float, photo: Path) -> float:
        return value * self.factor + self.by


def test_a_factory_gets_its_node_typed_and_a_schema_without_a_node_must_give_every_value(
    tmp_path: Path, photo: Path
) -> None:
    """The factory is called with its schema's fields: an int in the config arrives as the float the schema
    declares, a nested node as its dataclass. An implementation named only in ``auto.order`` has no node: its
    schema must then give every value, else the run stops in one line naming what it needs (a config mistake is
    not a reason to pass over an implementation)."""

    def register(registry: Any) -> None:
        registry.add_implementation("scaler", "shifting", Shifting, params=ShiftingSettings)

    plugins = load_plugins(
        extra=[(toy_plugin, TOY), (SimpleNamespace(register_implementations=hookimpl(register)), Origin("s", "t", "s"))]
    )
    typed = copy.deepcopy(BASE)
    typed["scaler"] = {"impl": "shifting", "shifting": {"factor": 3, "shift": {"by": 1}}}
    Shifting.made.clear()
    record = Runner(plugins, typed, photo, Store(tmp_path / "c1"), Store(tmp_path / "s1"), "readwrite").run(
        Pipeline.from_config(typed).select()
    )
    (factor, shift), *_ = Shifting.made
    assert type(factor) is float and shift == Shift(by=1.0) and type(shift.by) is float
    assert record.artifacts["b"].value == 4.0
    absent = copy.deepcopy(BASE)
    absent["scaler"] = {"impl": "auto", "auto": {"order": ["shifting"]}}
    Shifting.made.clear()
    runner = Runner(plugins, absent, photo, Store(tmp_path / "c2"), Store(tmp_path / "s2"), "readwrite")
    with pytest.raises(
        PsdrRoomError, match=r"scaler.shifting has no settings in the config \(its schema needs factor, "
    ):
        runner.run(Pipeline.from_config(absent).select())
    assert not Shifting.made
