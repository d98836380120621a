"""``psdr-room --help``: what a run can be told, read from the plugins' registry and config folders.

Hydra's own help composes the whole config once per config group (seconds); this one reads the folders'
YAML file names and the primary config's defaults list, and knows what Hydra does not: what each capability
is for and which stages the pipeline has. ``psdr-room --hydra-help`` still gives Hydra's options and
``psdr-room --cfg job`` the composed config.
"""

from __future__ import annotations

import textwrap
from importlib import resources
from pathlib import Path

import yaml

from .plugins import PluginSystem

USAGE = """\
psdr-room: one photo of a room -> an editable 3D scene (PSDR-Room, Yan et al., SIGGRAPH Asia 2023)

usage: psdr-room image=PHOTO [GROUP=OPTION ...] [KEY=VALUE ...]
       psdr-room photos=FOLDER --multirun [...]       one job per photo; GROUP=A,B sweeps"""

MORE = """\
more:  psdr-room --cfg job          the composed config (every KEY=VALUE a run can be given)
       psdr-room --settings NODE    what each setting of a stage or implementation means (--settings: the nodes)
       psdr-room --dag              the stages with their inputs and outputs (--dag=mermaid: a flowchart)
       psdr-room-plugins            every implementation and the plugin it comes from
       psdr-room --hydra-help       Hydra's own options (--multirun, --cfg, hydra.run.dir=, launchers)"""


def config_folders(config_module: str, searchpath: list[str]) -> list[Path]:
    """The primary config package's folder and the plugins' (``pkg://PACKAGE`` or ``file://FOLDER`` entries)."""
    folders = [Path(str(resources.files(config_module)))]
    for entry in searchpath:
        scheme, _, where = entry.partition("://")
        if scheme == "pkg":
            folders.append(Path(str(resources.files(where.replace("/", ".")))))
        elif scheme == "file":
            folders.append(Path(where))
    return [folder for folder in folders if folder.is_dir()]


def config_groups(folders: list[Path]) -> dict[str, list[str]]:
    """Config group (``hydra/launcher`` for nested ones) → its options, the YAML files in those folders."""
    groups: dict[str, set[str]] = {}
    for folder in folders:
        for file in folder.rglob("*.yaml"):
            group = file.parent.relative_to(folder).as_posix()
            if group != ".":
                groups.setdefault(group, set()).add(file.stem)
    return {group: sorted(options) for group, options in sorted(groups.items())}


def defaults(config_module: str) -> dict[str, str]:
    """The primary config's (``config.yaml``) defaults list in order: group (``stage@NAME`` for a stage node)
    → the option it selects."""
    data = yaml.safe_load(resources.files(config_module).joinpath("config.yaml").read_text()) or {}
    out: dict[str, str] = {}
    for entry in data.get("defaults") or []:
        if isinstance(entry, dict):
            out.update({str(k): str(v) for k, v in entry.items() if not str(k).startswith("override ")})
    return out


def help_text(plugins: PluginSystem, config_module: str) -> str:
    """The text of ``psdr-room --help``."""
    registry = plugins.registry
    groups = config_groups(config_folders(config_module, plugins.conf_searchpaths()))
    chosen = defaults(config_module)
    lines = [USAGE, "", "capabilities (GROUP=OPTION, * the default; psdr-room-plugins says where each comes from):"]
    for capability, description in registry.capabilities.items():
        options = groups.pop(capability, [])
        marked = ", ".join(o + ("*" if o == chosen.get(capability) else "") for o in options) or "(none configured)"
        lines += [f"  {capability:<16}{marked}", f"  {'':<16}{description}"]
    groups.pop("stage", None)
    stages = [group.removeprefix("stage@") for group in chosen if group.startswith("stage@")]
    others = {group: options for group, options in groups.items() if not group.startswith("hydra/job_logging")}
    if others:
        lines += ["", "other groups (+GROUP=OPTION adds one the config does not select, as +preset=preview):"]
        for group, options in others.items():
            name = group if group in chosen or group.startswith("hydra/") else f"+{group}"
            lines.append(f"  {name:<16}{', '.join(options)}")
    lines += ["", "stages, in order (STAGE.KEY=VALUE sets a parameter; run.until=, run.from=, run.only= slice a run):"]
    lines += textwrap.wrap(", ".join(stages), width=110, initial_indent="  ", subsequent_indent="  ")
    return "\n".join([*lines, "", MORE])
