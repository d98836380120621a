"""Command line: ``psdr-room image=PATH [overrides...]`` (a Hydra app) and ``psdr-room-plugins``.

Everything Hydra users expect works (``--multirun``, ``--cfg job``, ``hydra/launcher=joblib``). Before
Hydra runs, the overrides are checked so that a typo gets one line naming the key and the valid choices,
and plugin config directories (the ``conf_searchpath`` hook) are added to Hydra's search path.
"""

from __future__ import annotations

import logging
import os
import re
import sys
import traceback
from collections.abc import Callable
from pathlib import Path
from typing import Any, NoReturn

import hydra
from hydra import compose, initialize_config_module
from hydra.core.hydra_config import HydraConfig
from hydra.core.override_parser.overrides_parser import OverridesParser
from hydra.core.override_parser.types import ChoiceSweep, Override, RangeSweep
from hydra.errors import OverrideParseException
from hydra.types import RunMode
from omegaconf import DictConfig, OmegaConf, open_dict, read_write

from . import dag_view, settings_view, threads
from .choice import AUTO
from .errors import PsdrRoomError, disk_full
from .graph import Pipeline, check_stage_inputs
from .help import help_text
from .hydra_writes import check_hydra_writes
from .inputs import find_photos, require_file
from .interrupts import was_interrupted
from .ownership import claim
from .plugins import PluginSystem, plugin_system
from .run import execute, plan, resolve_config
from .settings import check_config

CONFIG_MODULE = "psdr_room_conf"
INTERRUPTED = "interrupted; finished stages are cached, rerun the same command to resume"
_VALUE_FLAGS = {
    "--cfg",
    "-c",
    "--package",
    "-p",
    "--config-path",
    "-cp",
    "--config-name",
    "-cn",
    "--config-dir",
    "-cd",
    "--experimental-rerun",
    "--shell-completion",
    "-sc",
}
_INFO_FLAGS = {"--help", "-h", "--hydra-help", "--info", "-i", "--cfg", "-c", "--shell-completion", "-sc", "--version"}


def _fail(message: str, code: int = 2) -> NoReturn:
    print(f"psdr-room: error: {message}", file=sys.stderr)
    sys.exit(code)


def searchpath_overrides(plugins: PluginSystem) -> list[str]:
    """The Hydra override adding plugin config directories to the search path (none if no plugin has one)."""
    paths = plugins.conf_searchpaths()
    return [f"hydra.searchpath=[{','.join(paths)}]"] if paths else []


def split_arguments(argv: list[str]) -> tuple[list[str], set[str]]:
    """Separate config overrides from Hydra's own flags (and their values)."""
    overrides, flags = [], set()
    skip = False
    for arg in argv:
        if skip:
            skip = False
        elif arg.startswith("-"):
            flags.add(arg.split("=")[0])
            skip = arg in _VALUE_FLAGS
        else:
            overrides.append(arg)
    return overrides, flags


def expand_photos(argv: list[str]) -> list[str]:
    """``photos=DIR`` (or a glob) → ``image=`` with every photo found as a sweep list, for ``--multirun``.

    Each photo becomes one job of the sweep with its own run folder; the quoting keeps commas, spaces and
    quotes in file names out of Hydra's override grammar.
    """
    given = [arg for arg in argv if arg.startswith("photos=")]
    if not given:
        return argv
    _, flags = split_arguments(argv)
    if not flags & {"--multirun", "-m"}:
        raise PsdrRoomError(
            f"{given[0]}: a folder of photos runs one job per photo; add --multirun (or give image=PATH for one photo)"
        )
    if len(given) > 1 or any(arg.startswith("image=") for arg in argv):
        raise PsdrRoomError(f"{given[0]}: give one photos=DIR or image=PATH, not both")
    photos = find_photos(given[0].removeprefix("photos="))
    images = ",".join(hydra_quote(str(photo)) for photo in photos)
    return [f"image={images}" if arg == given[0] else arg for arg in argv]


def hydra_quote(text: str) -> str:
    """``text`` as a single-quoted value of Hydra's override grammar (quotes, the backslashes before them and
    ``${`` escaped), so that it parses back to exactly ``text``."""
    text = re.sub(r"(\\*)('|$)", lambda m: m.group(1) * 2 + ("\\'" if m.group(2) else ""), text)
    return "'" + text.replace("${", "\\${") + "'"


def quote_photo(argv: list[str]) -> list[str]:
    """``image=PATH`` naming an existing file that Hydra's override grammar would not read as that one path
    (non-ASCII letters, brackets, ``#``, quotes, ``${`` that it would resolve, or a ``,`` outside
    ``--multirun``): quoted for it, so that paths work as people name them."""
    _, flags = split_arguments(argv)
    out = []
    for arg in argv:
        raw = arg.removeprefix("image=")
        if arg.startswith("image=") and raw[:1] not in ("'", '"') and Path(raw).expanduser().is_file():
            parsed = _parse(arg)
            if parsed is None or "${" in raw or (parsed.is_sweep_override() and not flags & {"--multirun", "-m"}):
                arg = f"image={hydra_quote(raw)}"
        out.append(arg)
    return out


def unknown_override(key: str, plugins: PluginSystem) -> PsdrRoomError:
    """The one-line error for overriding ``key`` that is not in the composed config: the same words as for an
    unknown key added with ``+`` (a did-you-mean and the valid names), never Hydra's hint to add it."""
    if key.startswith("hydra."):
        return PsdrRoomError(f"{key} is not a setting of Hydra; check the name against: psdr-room --cfg hydra")
    composed = OmegaConf.to_container(compose_config([], plugins), resolve=True)  # stages refer to each other
    assert isinstance(composed, dict)
    data: dict[str, Any] = {str(k): v for k, v in composed.items()}
    node = data
    *parents, last = key.split(".")
    for part in parents:
        node = node.setdefault(part, {}) if isinstance(node.get(part), dict | None) else {}
    node[last] = None
    try:
        check_config(data, Pipeline.from_config(data).nodes, plugins.registry)
    except PsdrRoomError as exc:
        return exc
    return PsdrRoomError(
        f"{key} is not in the config, and the schema of its stage or plugin does not say it "
        f"takes it; check the name against: psdr-room --cfg job"
    )


def compose_config(
    overrides: list[str], plugins: PluginSystem | None = None, return_hydra_config: bool = False
) -> DictConfig:
    """Compose the config as the CLI would (for tests, benchmarks and the preflight check); with
    ``return_hydra_config``, with the ``hydra`` node Hydra runs it with."""
    plugins = plugins or plugin_system()
    with initialize_config_module(config_module=CONFIG_MODULE, version_base="1.3"):
        return compose(
            config_name="config",
            overrides=[*overrides, *searchpath_overrides(plugins)],
            return_hydra_config=return_hydra_config,
        )


def composed(overrides: list[str], plugins: PluginSystem) -> DictConfig:
    """:func:`compose_config` with the ``hydra`` node, a composition error turned into one line."""
    try:
        return compose_config(overrides, plugins, return_hydra_config=True)
    except PsdrRoomError:
        raise
    except Exception as exc:  # Hydra/OmegaConf composition errors are multi-line: keep the first lines
        missing = re.match(r"Could not override '([^']+)'", str(exc))
        if missing:
            raise unknown_override(missing.group(1), plugins) from None
        lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
        raise PsdrRoomError(f"invalid override: {' '.join(lines[:2])}") from None


def first_job(parsed: list[Override], plugins: PluginSystem) -> DictConfig:
    """The config (with the ``hydra`` node) of a sweep's first job: each sweep of the command line and of
    ``hydra.sweeper.params`` at its first value."""
    given = [o for o in (_first_value(o) for o in parsed) if o is not None]
    cfg = composed(given, plugins)
    params = OmegaConf.select(cfg, "hydra.sweeper.params") or {}
    swept = {o.key_or_group for o in parsed}
    from_config = [o for o in (_parse(f"{key}={value}") for key, value in params.items()) if o is not None]
    more = [v for v in (_first_value(o) for o in from_config if o.key_or_group not in swept) if v is not None]
    return composed([*given, *more], plugins) if more else cfg


def _first_value(override: Override) -> str | None:
    """``override`` as a sweep's first job gets it; None for a sweep whose values only its sweeper knows."""
    if not override.is_sweep_override():
        return override.input_line
    if not isinstance(override.value(), ChoiceSweep | RangeSweep):
        return None
    return f"{override.get_key_element()}={next(iter(override.sweep_string_iterator()))}"


def preflight(argv: list[str], plugins: PluginSystem) -> None:
    """Check the overrides before Hydra runs; raise :class:`PsdrRoomError` with one line if one is wrong."""
    overrides, flags = split_arguments(argv)
    if "image=" in overrides:
        raise PsdrRoomError("image= is empty; add image=PATH/TO/photo.jpg to the command line")
    try:
        parsed: list[Override] = OverridesParser.create().parse_overrides(overrides)
    except OverrideParseException as exc:
        photo = next((o for o in overrides if o.startswith("image=")), None)
        if photo is not None and _parse(photo) is None:  # quote_photo() quoted it if the file existed
            raise PsdrRoomError(
                f"{photo[6:]}: no such file; pass image=PATH to an existing photo (quote a path Hydra's "
                f"grammar cannot read: image=\"'{photo[6:]}'\")"
            ) from None
        raise PsdrRoomError(f"invalid override: {str(exc).splitlines()[0]}") from None
    for override in parsed:
        group = override.key_or_group
        if group in plugins.registry.capabilities and not override.is_delete():
            for name in override.sweep_string_iterator() if override.is_sweep_override() else [override.value()]:
                plugins.registry.implementation(group, str(name))
    if flags & _INFO_FLAGS:
        return  # info flags need no image and write nothing
    if flags & {"--multirun", "-m"}:
        check_hydra_writes(first_job(parsed, plugins), sweeping=True)
        return  # each job's photo and settings are checked by that job, in its own folder
    image = [o for o in parsed if o.key_or_group == "image"]
    if image and image[0].is_sweep_override():
        raw = next(o for o in overrides if o.startswith("image="))
        raise PsdrRoomError(
            f"{raw}: the ',' makes this a list of photos; quote the path: image=\"'{raw[6:]}'\" "
            "(or add --multirun to run each)"
        )
    cfg = composed(overrides, plugins)
    check_hydra_writes(cfg, sweeping=False)
    with read_write(cfg), open_dict(cfg):
        del cfg["hydra"]  # the job's config, as Hydra hands it over
    data = resolve_config(cfg)
    if not all(o.key_or_group == "image" or o.key_or_group.startswith("hydra.") for o in parsed):
        plan(data, plugins)  # the default settings are valid: only overridden ones can be wrong
    photo_file = Path(str(data["image"])).expanduser()
    typed = next((o.removeprefix("image=") for o in reversed(overrides) if o.startswith("image=")), "")
    if "${" in typed and typed[:1] not in ("'", '"') and not photo_file.exists():
        photo_file = Path(typed).expanduser()  # neither the name as typed nor what Hydra makes of it is a file
    require_file(photo_file)


def dag(argv: list[str], plugins: PluginSystem) -> str:
    """``psdr-room --dag [overrides...]`` (or ``--dag=mermaid``, ``--dag mermaid``): the pipeline of the config
    these overrides compose, as :mod:`.dag_view` shows it. Nothing runs, and no photo is needed."""
    form, data = _flag_and_config(argv, "--dag", plugins, takes=lambda arg: arg in dag_view.FORMS)
    form = form or "text"
    if form not in dag_view.FORMS:
        raise PsdrRoomError(f"--dag={form} is not a form of the graph; use --dag (text) or --dag=mermaid")
    pipeline = Pipeline.from_config(data, provided=data.get("inject") or {})
    check_stage_inputs(pipeline.nodes, plugins.registry)
    show = dag_view.mermaid if form == "mermaid" else dag_view.text
    return show(pipeline, data, plugins.registry)


def settings_reference(argv: list[str], plugins: PluginSystem) -> str:
    """``psdr-room --settings NODE [overrides...]`` (``--settings=NODE``): what each setting of the stage or
    implementation ``NODE`` (``place_objects``, ``segmentation.layout``) means and its value in the config these
    overrides compose, as :mod:`.settings_view` shows it. Without NODE, the nodes there are. Nothing runs."""
    name, data = _flag_and_config(argv, "--settings", plugins, takes=lambda arg: "=" not in arg and arg[:1] != "-")
    if not name:
        nodes = sorted(settings_view.schemas(data, plugins.registry))
        return "settings nodes (psdr-room --settings NODE):\n" + "\n".join(f"  {n}" for n in nodes)
    return settings_view.text(name, data, plugins.registry)


def _flag_and_config(
    argv: list[str], flag: str, plugins: PluginSystem, *, takes: Callable[[str], bool]
) -> tuple[str, dict[str, Any]]:
    """The value of ``flag`` in ``argv`` (``--flag=VALUE``, or ``--flag VALUE`` where ``takes(VALUE)``; empty
    without one) and the resolved config the other arguments compose, no photo needed."""
    at = next(i for i, arg in enumerate(argv) if arg.split("=")[0] == flag)
    value = argv[at].partition("=")[2]
    rest = [*argv[:at], *argv[at + 1 :]]
    if not value and argv[at + 1 : at + 2] and takes(argv[at + 1]):
        value, rest = argv[at + 1], [*argv[:at], *argv[at + 2 :]]
    cfg = composed(split_arguments(rest)[0], plugins)
    with read_write(cfg), open_dict(cfg):
        del cfg["hydra"]
    return value, resolve_config(cfg, missing_ok=True)


def _print(text: str) -> None:
    """Print ``text``; a reader that closed the pipe (``| head``) has had what it wanted: no traceback."""
    try:
        print(text, flush=True)
    except BrokenPipeError:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # Python's flush at exit must not fail too


def _parse(override: str) -> Override | None:
    """``override`` parsed by Hydra's grammar, or None when the grammar cannot read it."""
    try:
        return OverridesParser.create().parse_overrides([override])[0]
    except OverrideParseException:
        return None


def main() -> None:
    """Entry point of ``psdr-room``."""
    try:
        argv = quote_photo(expand_photos(sys.argv[1:]))
        plugins = plugin_system()
        flags = split_arguments(argv)[1]
        if flags & {"--help", "-h"}:
            _print(help_text(plugins, CONFIG_MODULE))
            return
        if "--dag" in flags:
            _print(dag(argv, plugins))
            return
        if "--settings" in flags:
            _print(settings_reference(argv, plugins))
            return
        preflight(argv, plugins)
    except PsdrRoomError as exc:
        _fail(str(exc))
    sys.argv = [sys.argv[0], *argv, *searchpath_overrides(plugins)]
    _app()


@hydra.main(version_base="1.3", config_path=f"pkg://{CONFIG_MODULE}", config_name="config")
def _app(cfg: DictConfig) -> None:
    hydra_cfg = HydraConfig.get()
    run_dir = Path(hydra_cfg.runtime.output_dir)
    sweeping = hydra_cfg.mode == RunMode.MULTIRUN
    try:
        if sweeping:  # the sweep folder, like the job's: new, empty or ours (preflight checked it)
            claim(Path(hydra_cfg.runtime.cwd) / hydra_cfg.sweep.dir)
        claim(run_dir)  # new, empty or ours (preflight checked it before Hydra wrote into it)
        count, source = threads.allotment(cfg.run.get("threads"), hydra_cfg.launcher)
        threads.apply(count)
        if source != "cores":  # an allotment (sweep worker, scheduler, run.threads): say where it came from
            logging.getLogger("psdr_room").info("threads: %d (%s)", count, source)
        execute(cfg, run_dir)
    except PsdrRoomError as exc:
        _fail_run(str(exc), exc.exit_code, sweeping)
    except PermissionError as exc:
        where = exc.filename or exc
        _fail_run(f"{where}: permission denied; make it readable (or writable), or choose another path", 2, sweeping)
    except KeyboardInterrupt:
        _fail_run(INTERRUPTED, 130, False)
    except Exception as exc:
        if was_interrupted(exc):  # an extension module stopped while it loads raises ImportError from it
            _fail_run(INTERRUPTED, 130, False)
            return
        full = disk_full(exc, run_dir)
        if full is not None:
            _fail_run(str(full), full.exit_code, sweeping)
            return
        log = run_dir / "error.log"
        log.parent.mkdir(parents=True, exist_ok=True)
        log.write_text(traceback.format_exc())
        _fail_run(f"internal error: {type(exc).__name__}: {exc} (traceback in {log}; please report it)", 1, sweeping)


def _fail_run(message: str, code: int, sweeping: bool) -> None:
    """:func:`_fail`, with the line also in the run folder's log file (``psdr-room-summary`` reads it there).

    In a sweep the job ends normally instead, so the other jobs go on; the sweep's summary
    (the sweep callback in ``hydra.callbacks``) lists it and makes the sweep's exit status 1.
    """
    record = logging.LogRecord("psdr_room", logging.ERROR, __file__, 0, message, None, None)
    for handler in logging.getLogger().handlers:
        if isinstance(handler, logging.FileHandler):
            handler.handle(record)
    print(f"psdr-room: error: {message}", file=sys.stderr)
    if not sweeping:
        sys.exit(code)


def plugins_main() -> None:
    """Entry point of ``psdr-room-plugins``: every capability, its implementations, and where each came from."""
    plugins = plugin_system()
    defaults = compose_config([], plugins)
    registry = plugins.registry
    rows = [("capability", "implementation", "version", "default", "provided by")]
    for capability in registry.capabilities:
        names = sorted(n for c, n in registry.implementations if c == capability)
        default = defaults.get(capability, {}).get("impl") if capability in defaults else None
        if not names:
            rows.append((capability, "-", "-", "", "(none yet)"))
        if default == AUTO:
            order = ", ".join(defaults[capability].get(AUTO, {}).get("order") or [])
            rows.append((capability, AUTO, "-", "*", f"(engine) the first usable of: {order}"))
        for name in names:
            impl = registry.implementations[(capability, name)]
            rows.append((capability, name, impl.version, "*" if name == default else "", str(impl.origin)))
    widths = [max(len(r[i]) for r in rows) for i in range(4)]
    for row in rows:
        print("  ".join(cell.ljust(w) for cell, w in zip(row[:4], widths)) + "  " + row[4])
    print("\ncapabilities:")
    for capability, description in registry.capabilities.items():
        print(f"  {capability:<15} {description}")
    print("\nstages:")
    for name, stage in sorted(registry.stages.items()):
        uses = f" uses {', '.join(stage.uses)}" if stage.uses else ""
        print(f"  {name:<15} v{stage.version}  {stage.origin}{uses}")
    for (capability, name), origins in sorted(registry.conflicts.items()):
        print(f"\nconflict: {capability}={name} is registered by " + " and ".join(str(o) for o in origins))
    for plugin, why in sorted(registry.failures.items()):
        print(f"\nleft out: plugin '{plugin}': {why}")
