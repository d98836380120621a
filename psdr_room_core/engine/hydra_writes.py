"""Where Hydra will write a run, resolved as Hydra resolves it and checked before it writes anything.

Hydra writes into the run folder ``hydra.run.dir`` (with ``--multirun``: the sweep folder ``hydra.sweep.dir``
and a job folder ``hydra.sweep.subdir`` in it), saves the job's config into ``hydra.output_subdir`` of the job
folder, and opens the files named by the ``filename`` of the handlers of ``hydra.job_logging`` and
``hydra.hydra_logging``. Each is resolved here the way Hydra will (``${now:...}``, ``${oc.env:...}``,
``${hydra:...}`` and references to other keys, with the job's ``hydra.runtime.output_dir`` set), so a folder
named by interpolation is checked like a plain one: the run or sweep folder must be new, empty or psdr-room's
and writable, and everything else Hydra writes must lie inside it.
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from hydra.core.hydra_config import HydraConfig
from hydra.types import RunMode
from omegaconf import DictConfig, OmegaConf, open_dict, read_write
from omegaconf.errors import OmegaConfBaseException

from .bounded import excerpt
from .errors import PsdrRoomError
from .ownership import check_replaceable

LOGGING = ("hydra.hydra_logging", "hydra.job_logging")
"""The logging configs whose file handlers Hydra opens."""


def check_hydra_writes(cfg: DictConfig, sweeping: bool) -> None:
    """Refuse, in one line naming the key, any place Hydra would write for ``cfg`` (composed with its ``hydra``
    node) that is not psdr-room's to write: a run or sweep folder holding files of someone else's or that cannot
    be written, a key that cannot be resolved, and a job folder, config folder or log file outside the run or
    sweep folder. ``sweeping``: a ``--multirun`` sweep, checked as its first job (job number 0). Sets in ``cfg``
    what Hydra sets before it writes: ``hydra.mode``, the job's number and id, ``hydra.runtime.output_dir``."""
    with read_write(cfg.hydra), open_dict(cfg.hydra):
        cfg.hydra.mode = RunMode.MULTIRUN if sweeping else RunMode.RUN
        if sweeping:  # as Hydra's launcher numbers the first job
            cfg.hydra.job.num = 0
            cfg.hydra.job.id = "job_id_for_0"
    top_key = "hydra.sweep.dir" if sweeping else "hydra.run.dir"
    with _hydra_config(cfg):
        top = Path(os.path.abspath(str(_resolved(cfg, top_key))))
        _check_folder(top, top_key, _raw(cfg, top_key))
        job = (
            _inside(top, top / str(_resolved(cfg, "hydra.sweep.subdir")), cfg, "hydra.sweep.subdir")
            if sweeping
            else top
        )
    with read_write(cfg.hydra), open_dict(cfg.hydra):
        cfg.hydra.runtime.output_dir = str(job)
    with _hydra_config(cfg):
        subdir = _resolved(cfg, "hydra.output_subdir")
        if subdir is not None:
            _inside(top, job / str(subdir), cfg, "hydra.output_subdir")
        for logging_key in LOGGING:  # a relative file name is opened from the working folder, the job's with chdir
            base = job if logging_key == "hydra.job_logging" and _resolved(cfg, "hydra.job.chdir") else Path.cwd()
            handlers = OmegaConf.select(cfg, f"{logging_key}.handlers")
            for name, handler in handlers.items() if isinstance(handlers, DictConfig) else ():
                if isinstance(handler, DictConfig) and "filename" in handler:
                    key = ".".join((logging_key, "handlers", str(name), "filename"))
                    _inside(top, base / str(_resolved(cfg, key)), cfg, key)


def _check_folder(folder: Path, key: str, raw: str) -> None:
    """Refuse the run or sweep folder ``folder`` (``key=raw``) unless it is absent, empty or psdr-room's, and
    can be made and written in."""
    check_replaceable(folder, key)
    existing = next(p for p in (folder, *folder.parents) if p.exists())
    if not os.access(existing, os.W_OK | os.X_OK):
        raise PsdrRoomError(
            f"{key}={excerpt(raw)}: {existing} cannot be written (permission denied); give {key}= a folder you can "
            "write to"
        )


def _inside(folder: Path, path: Path, cfg: DictConfig, key: str) -> Path:
    """``path`` made absolute (``..`` taken out), refused in one line naming ``key`` unless inside ``folder``."""
    absolute = Path(os.path.normpath(os.path.abspath(path)))
    if not absolute.is_relative_to(folder):
        raise PsdrRoomError(
            f"{key}={excerpt(_raw(cfg, key))}: {absolute} is outside {folder}, where this run writes; give {key}= "
            "a name inside it"
        )
    return absolute


def _resolved(cfg: DictConfig, key: str) -> Any:
    """The value of ``key`` resolved, or one line naming the key that cannot be."""
    try:
        return OmegaConf.select(cfg, key, throw_on_missing=True)
    except OmegaConfBaseException as exc:
        reason = re.sub(r"^\w+ raised while resolving interpolation: ", "", str(exc).splitlines()[0]).strip('"')
        raise PsdrRoomError(
            f"{key}={excerpt(_raw(cfg, key))}: cannot be resolved ({excerpt(reason)}); set what it refers to or give "
            "a plain path"
        ) from None


def _raw(cfg: DictConfig, key: str) -> str:
    """The value of ``key`` as written, interpolations unresolved."""
    parent, _, name = key.rpartition(".")
    node = OmegaConf.to_container(OmegaConf.select(cfg, parent), resolve=False)
    assert isinstance(node, dict)
    return str(node.get(name))


@contextmanager
def _hydra_config(cfg: DictConfig) -> Iterator[None]:
    """``cfg`` as the config ``${hydra:...}`` resolves against, as while Hydra runs a job."""
    instance = HydraConfig.instance()
    previous = instance.cfg
    instance.set_config(cfg)
    try:
        yield
    finally:
        instance.cfg = previous
