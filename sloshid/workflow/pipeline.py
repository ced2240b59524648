"""Declarative pipelines: validate a TOML file, run its stages in order, cache each stage by content hash.

A stage's cache key hashes its settings slice, the bytes of every file it reads, the keys of the stages it
consumes and the package version, so changing one stage re-runs it and everything after it, and an
unchanged re-run only copies finished outputs. Each run writes `<output>/<pipeline>/<run-id>/`.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import shutil
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from datetime import datetime, timezone
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal, TypeVar

from sloshid import __version__
from sloshid.core.atomic import (
    SCHEMA_VERSION,
    atomic_dir,
    check_schema,
    remove_orphans,
    versioned,
    write_text,
    writer_gone,
    writer_tag,
)
from sloshid.core.errors import SettingError, UserError, input_file
from sloshid.core.hashing import file_sha256, json_sha256
from sloshid.core.outputs import writable_folder
from sloshid.core.parallel import check_workers
from sloshid.core.settings import did_you_mean, from_dict, load_toml

if TYPE_CHECKING:
    from _typeshed import DataclassInstance

    SettingsT = TypeVar("SettingsT", bound=DataclassInstance)

logger = logging.getLogger("sloshid.workflow")
"""Each stage's progress in a pipeline run (INFO), unless the caller passes its own `log`."""


@dataclass
class RunSettings:
    """The [run] table: how the pipeline runs."""

    name: str = ""
    """Pipeline name used in the output path; default: the pipeline file's name without .toml."""
    workers: int = 1
    """Dask workers for stages that process several inputs (tracking several videos)."""
    on_error: Literal["stop", "continue"] = "stop"
    """'stop': a failing stage ends the run; 'continue': stages that do not need it still run."""
    output_dir: str = "reports"
    """Where runs are written, relative to the current directory: <output_dir>/<name>/<run-id>/."""

    def __post_init__(self) -> None:
        check_workers(self.workers)
        if self.name and (Path(self.name).name != self.name or self.name.startswith(".") or "\0" in self.name):
            raise UserError(
                f"[run].name must be a plain folder name (no '/' or NUL, not starting with '.'), got {self.name!r}."
            )


@dataclass
class ReportSettings:
    """The [report] table: how the run's index.html looks."""

    title: str = ""
    """Page title; default 'sloshid run: <pipeline name>'."""


@dataclass(frozen=True)
class StageContext:
    """What a stage gets besides its settings: where to write, what ran before, how to run."""

    out_dir: Path
    """Empty directory for this stage's outputs (renamed into place only if the stage succeeds)."""
    upstream: dict[str, Path]
    """Output directories of the earlier stages of this run, by stage name (their cache folders)."""
    run: RunSettings


@dataclass(frozen=True)
class Stage:
    """One kind of stage: its settings type, the files and stages it reads, and the function that runs it."""

    name: str
    settings_type: type[Any]
    run: Callable[[Any, StageContext], dict[str, Any]]
    """Writes outputs into ctx.out_dir and returns a JSON-able summary for the index page."""
    input_files: Callable[[Any], list[Path]] = lambda s: []
    needs: Callable[[Any, set[str]], list[str]] = lambda s, present: []
    """Names of earlier stages whose outputs it consumes, given the stages present in the pipeline."""
    check: Callable[[Any], None] = lambda s: None
    """Validation that needs more than the settings' own types (files that must parse), run before any stage."""
    check_with: Callable[[Any, dict[str, Any]], None] = lambda s, others: None
    """Validation against the other stages' settings (by stage name), run before any stage."""


@dataclass
class StageRecord:
    """What happened to one stage in one run."""

    name: str
    key: str
    status: Literal["ran", "cached", "failed", "skipped"]
    seconds: float
    summary: dict[str, Any] = field(default_factory=dict)
    error: str = ""


@dataclass
class PipelineRun:
    """The outcome of `run_pipeline`: where the run was written and each stage's record."""

    run_dir: Path
    index_html: Path
    stages: list[StageRecord]

    @property
    def ok(self) -> bool:
        """True when no stage failed."""
        return all(s.status in ("ran", "cached") for s in self.stages)


def resolve_paths(settings: SettingsT, base: Path, where: str) -> SettingsT:
    """Make every Path field (or list of Paths) of a settings dataclass absolute against `base`; check existence."""
    changes: dict[str, Path | list[Path] | tuple[Path, ...]] = {}
    for f in dataclasses.fields(settings):
        value = getattr(settings, f.name)
        if isinstance(value, Path):
            changes[f.name] = _existing(base / value, f"{where}.{f.name}")
        elif isinstance(value, (list, tuple)) and value and all(isinstance(v, Path) for v in value):
            changes[f.name] = type(value)(_existing(base / v, f"{where}.{f.name}") for v in value)
    return dataclasses.replace(settings, **changes) if changes else settings


def _in_section(path: Path, name: str) -> Callable[[str], str]:
    """Names a setting of stage `name` as the pipeline file does: '<file>: [<stage>].<setting>'."""
    return lambda setting: f"{path}: [{name}].{setting}"


def _existing(path: Path, where: str) -> Path:
    """The resolved path, or a UserError naming the key when it is not a readable file (videos, signals and
    scenarios are all files)."""
    p = input_file(path.resolve(), f"{where}:")
    if not p.is_file():  # hashed for the cache, then read by its stage: a pipe would give its data to the hash alone
        raise UserError(
            f"{where}: {p} is a pipe; a pipeline reads each input twice (for its cache, then to run the "
            "stage), so it must be a regular file."
        )
    return p


@dataclass
class Pipeline:
    """A validated pipeline file: run settings and the settings of each stage it declares, in run order."""

    path: Path
    run: RunSettings
    report: ReportSettings
    stages: list[tuple[Stage, Any]]

    @classmethod
    def load(cls, path: str | Path, registry: dict[str, Stage]) -> Pipeline:
        """Read and validate everything before anything runs: keys, types, units, paths."""
        path = Path(path)
        raw = load_toml(path)
        allowed = ["run", "report", *registry]
        for key in raw:
            if key not in allowed:
                raise UserError(f"{path}: unknown section [{key}]{did_you_mean(key, allowed)}.")
        run = from_dict(RunSettings, raw.get("run", {}), "[run]")
        if not run.name:
            run = dataclasses.replace(run, name=path.stem)
        report = from_dict(ReportSettings, raw.get("report", {}), "[report]")
        if not report.title:
            report.title = f"sloshid run: {run.name}"
        stages: list[tuple[Stage, Any]] = []
        for name, stage in registry.items():
            if name in raw:
                if not isinstance(raw[name], dict):
                    raise UserError(f"{path}: [{name}] must be a table.")
                settings = from_dict(stage.settings_type, raw[name], f"[{name}]")
                settings = resolve_paths(settings, path.parent, f"[{name}]")
                stage.check(settings)
                stages.append((stage, settings))
        if not stages:
            raise UserError(f"{path} declares no stage; add one of {', '.join(f'[{n}]' for n in registry)}.")
        present = {s.name for s, _ in stages}
        every = {s.name: settings for s, settings in stages}
        for stage, settings in stages:
            try:
                stage.check_with(settings, every)
            except SettingError as exc:
                raise UserError(str(exc.named(_in_section(path, stage.name)))) from None
        for stage, settings in stages:
            for need in stage.needs(settings, present):
                if need not in present:
                    raise UserError(f"{path}: [{stage.name}] needs a [{need}] section or its own input files.")
            # asked for in so many words, an identified liquid without an [identify] stage would silently be the
            # scenario's [liquid]
            if raw[stage.name].get("use_identified") is True and "identify" not in present:
                raise UserError(
                    f"{path}: [{stage.name}].use_identified = true, but the pipeline has no [identify] stage; add "
                    "one, or drop the key to plan for the scenario's [liquid]."
                )
        return cls(path, run, report, stages)


def _settings_json(settings: Any) -> dict[str, Any]:
    """Settings as plain JSON values (paths as strings)."""
    return json.loads(json.dumps(dataclasses.asdict(settings), default=str))


def _copy_tree(src: Path, dst: Path) -> None:
    """Copy a finished stage's outputs into a run: copies, not links, so that editing a file in one run's folder
    changes neither the cache nor any other run. All or nothing: copytree goes on past a failed file (a full disk
    left 0-byte copies), so the copy is made beside `dst` and put in place whole."""
    with atomic_dir(dst) as tmp:
        try:
            shutil.copytree(src, tmp, ignore=shutil.ignore_patterns(FILES_JSON), dirs_exist_ok=True)
        except shutil.Error as exc:  # each failed file's (source, destination, reason): the first reason says it
            raise OSError(exc.args[0][0][2]) from None


FILES_JSON = ".files.json"
"""In each cached stage folder: the SHA-256 of every file the stage wrote, checked before the folder is reused."""


def _file_hashes(folder: Path) -> dict[str, str]:
    """SHA-256 of every file under `folder` but FILES_JSON, by path relative to it."""
    return {
        p.relative_to(folder).as_posix(): file_sha256(p)
        for p in sorted(folder.rglob("*"))
        if p.is_file() and p.name != FILES_JSON
    }


def _cache_damage(cache: Path) -> str | None:
    """What changed in a cached stage folder since the stage wrote it (a file missing, edited or added), or None."""
    try:
        written = json.loads((cache / FILES_JSON).read_text())
    except (OSError, ValueError):
        written = None
    if not isinstance(written, dict):
        return "it has no readable file hashes (an older sloshid wrote none)"
    check_schema(written, cache / FILES_JSON)
    written.pop("schema_version", None)
    now = _file_hashes(cache)
    for name, digest in written.items():
        if name not in now:
            return f"{name} is missing"
        if now[name] != digest:
            return f"{name} was changed"
    extra = sorted(set(now) - set(written))
    return f"{extra[0]} was added" if extra else None


def _stage_error(exc: Exception, stage: str) -> str:
    """One sentence for a failed stage: a setting named as the pipeline's key, any other error as it reads."""
    if isinstance(exc, SettingError):
        return str(exc.named(lambda setting: f"[{stage}].{setting}"))
    return str(exc) if isinstance(exc, UserError) else f"unexpected error: {type(exc).__name__}: {exc}"


def _new_run_dir(pipeline: Pipeline) -> tuple[Path, Path, str]:
    """(pipeline root, this run's folder, run id); the run folder is created, after checking it can be."""
    root = Path(pipeline.run.output_dir) / pipeline.run.name
    run_id = datetime.now(timezone.utc).strftime("%Y%m%d-%H%M%S-%f")
    run_dir = root / run_id
    writable_folder(run_dir, "the run folder", run_dir)
    writable_folder(root / ".cache" / "stage", "the stages' cache", root / ".cache")  # a file there failed every stage
    if root.is_dir():
        _remove_killed_runs(root)
    try:
        run_dir.mkdir(parents=True)
        (run_dir / RUNNING_MARK.format(writer=writer_tag())).touch()
    except OSError as exc:
        raise UserError(f"could not create the run folder {run_dir}: {exc.strerror or exc}.") from None
    return root, run_dir, run_id


def _run_stage(
    stage: Stage, settings: Any, key: str, cache: Path, ctx: StageContext, log: Callable[[str], None]
) -> StageRecord:
    """Run one stage into its cache folder (or reuse it) and record what happened; a failure is recorded."""
    start = time.perf_counter()
    if cache.is_symlink():  # not the folder the stage wrote: the link goes, what it points at is left alone
        log(f"[{stage.name}] its cache folder {cache} is a link, not the folder it wrote; running it again")
        cache.unlink()
    damage = _cache_damage(cache) if cache.is_dir() else None
    if damage is not None:  # run again, not reused with a file lost or edited (a run's folder once linked into it)
        log(f"[{stage.name}] its cached outputs differ from what it wrote ({damage}), running it again")
        shutil.rmtree(cache)
    status: Literal["ran", "cached"]
    if (cache / "summary.json").exists():
        log(f"[{stage.name}] unchanged, reusing {cache}")
        status = "cached"
    else:
        log(f"[{stage.name}] running")
        try:
            with atomic_dir(cache) as tmp:
                summary = stage.run(settings, replace(ctx, out_dir=tmp))
                write_text(tmp / "summary.json", json.dumps(versioned(summary), indent=2, default=str))
                write_text(tmp / FILES_JSON, json.dumps(versioned(_file_hashes(tmp)), indent=1))
            status = "ran"
        except Exception as exc:  # recorded, so the run still gets its manifest and index
            if not (cache / "summary.json").exists() or _cache_damage(cache) is not None:
                error = _stage_error(exc, stage.name)
                log(f"[{stage.name}] failed")  # the reason is the record's, which the command prints once at the end
                return StageRecord(stage.name, key, "failed", time.perf_counter() - start, error=error)
            # another run of the same pipeline finished this very stage (same key: same outputs) first
            log(f"[{stage.name}] another run wrote its outputs meanwhile, reusing {cache}")
            status = "cached"
    _copy_tree(cache, ctx.out_dir)
    summary = json.loads((cache / "summary.json").read_text())
    check_schema(summary, cache / "summary.json")
    summary.pop("schema_version", None)
    return StageRecord(stage.name, key, status, time.perf_counter() - start, summary)


def run_pipeline(
    pipeline: Pipeline,
    output_dir: str | Path | None = None,
    write_index: Callable[[Path, list[StageRecord]], Path] | None = None,
    log: Callable[[str], None] | None = None,
) -> PipelineRun:
    """Run every stage (or reuse its cached outputs) and write the run directory with manifest and index; each stage's
    progress goes to `log` (default: the `sloshid.workflow` logger, at INFO)."""
    log = log or logger.info
    if output_dir:  # the manifest records the folder the run is written to, not the file's default
        pipeline = replace(pipeline, run=replace(pipeline.run, output_dir=str(output_dir)))
    root, run_dir, run_id = _new_run_dir(pipeline)
    input_hashes: dict[str, str] = {}
    try:
        records = _run_stages(pipeline, root, run_dir, input_hashes, log)
        manifest = {
            "schema_version": SCHEMA_VERSION,
            "pipeline": str(pipeline.path.resolve()),
            "run_id": run_id,
            "sloshid_version": __version__,
            "settings": {
                "run": _settings_json(pipeline.run),
                **{s.name: _settings_json(c) for s, c in pipeline.stages},
            },
            "input_sha256": input_hashes,
            "stages": [dataclasses.asdict(r) for r in records],
        }
        write_text(run_dir / "manifest.json", json.dumps(manifest, indent=2, default=str))
        index = write_index(run_dir, records) if write_index else run_dir / "manifest.json"
    except BaseException:  # a run folder that cannot be finished (a full disk, Ctrl-C) is not left half-written
        shutil.rmtree(run_dir, ignore_errors=True)
        raise
    (run_dir / RUNNING_MARK.format(writer=writer_tag())).unlink()
    return PipelineRun(run_dir, index, records)


RUNNING_MARK = ".running-{writer}"
"""In a run folder while its run goes on (`writer_tag`): one whose process is gone (killed) is removed by the next run
on the same machine."""


def _remove_killed_runs(root: Path) -> None:
    """Remove what runs killed outright (SIGKILL, a power cut) left under `root`: their unfinished run folders and
    the temporary folders of the stages they were caching."""
    for mark in root.glob("*/" + RUNNING_MARK.format(writer="*")):
        if writer_gone(mark.name):
            shutil.rmtree(mark.parent, ignore_errors=True)
    for stage in (root / ".cache").glob("*"):
        if stage.is_dir():
            remove_orphans(stage)


def _run_stages(
    pipeline: Pipeline, root: Path, run_dir: Path, input_hashes: dict[str, str], log: Callable[[str], None]
) -> list[StageRecord]:
    """Run (or reuse) every stage in order into the run folder; a stage whose inputs failed is skipped."""
    keys: dict[str, str] = {}
    caches: dict[str, Path] = {}  # each stage's content-addressed outputs: what later stages read
    records: list[StageRecord] = []
    failed: set[str] = set()
    present = {s.name for s, _ in pipeline.stages}
    for stage, settings in pipeline.stages:
        needs = stage.needs(settings, present)
        if failed.intersection(needs) or (failed and pipeline.run.on_error == "stop"):
            records.append(StageRecord(stage.name, "", "skipped", 0.0, error="an earlier stage failed"))
            failed.add(stage.name)
            continue
        files = {str(p): input_hashes.setdefault(str(p), file_sha256(p)) for p in stage.input_files(settings)}
        upstream = {n: keys[n] for n in needs}
        key = json_sha256(
            {"settings": _settings_json(settings), "files": files, "upstream": upstream, "version": __version__}
        )[:16]
        keys[stage.name] = key
        caches[stage.name] = root / ".cache" / stage.name / key
        # later stages read the cached outputs, not this run's copies: what they record of their inputs (identify's
        # sources, its input warnings) is then the same in every run that reuses them, and outlives this run folder
        ctx = StageContext(run_dir / stage.name, {n: caches[n] for n in needs}, pipeline.run)
        records.append(_run_stage(stage, settings, key, caches[stage.name], ctx, log))
        if records[-1].status == "failed":
            failed.add(stage.name)
    return records
