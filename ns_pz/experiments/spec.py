"""Experiment specs: a declarative, versioned description of one benchmark table.

A spec is a TOML file::

    version = 1
    name = "frozenlake-single"
    title = "FrozenLake 4x4, single change of the intended-move probability"
    env = "ns_pz/FrozenLake-v0"
    env_kwargs = {}                      # constructor arguments of the family
    params = { slip = 0.7 }              # θ_0; others take their defaults
    notifications = ["none", "detailed"]

    [change]
    kind = "single"                      # "single", "continuous" or "none"
    param = "slip"
    first_step = 1                       # k: the first transition that uses the new θ
    to = [0.4, 0.6, 0.8]                 # single: one setting per value

    [sizes.quick]
    episodes = 30
    horizon = 100

    [monitor]                            # optional: the detector of the "detector" column
    name = "cusum"                       # a name of ns_pz.monitor.catalog
    level = "detailed"                   # what of its notification reaches the agent
    params = { threshold = 10.0 }

    [[agents]]
    name = "mcts"                        # a name of ns_pz.agents.catalog
    label = "MCTS"                       # how tables call it (default: the name)
    params = { c = 1.4142 }              # hyper-parameters for every size
    quick = { iterations = 100 }         # ... overridden per size (nested tables merged)
    notifications = ["none"]             # optional: the levels this agent runs at

``notifications`` lists the columns: the levels ``"none"`` (WON), ``"basic"``, ``"detailed"``
(WN: the exact oracle) and ``"detector"`` (WD): the ``[monitor]`` table's monitor, honest,
telling the agent what it detects at that table's ``level``. An agent runs in the detector column
if it runs at that level.

A scalar given for a probability vector means its first entry (the intended outcome) with the
rest split equally over the other outcomes, the NS-Gym rule; a list gives the vector itself.
A continuous change adds ``by`` to the parameter at every step from ``first_step`` on, ``steps``
times (every step if absent), clipped to the parameter's bounds.

:func:`load_spec` checks everything before any trial runs: unknown fields, envs, parameters,
agents and hyper-parameters, values out of bounds, agents that need a model the env cannot give.
Errors name the file, the field and what is allowed.
"""

from __future__ import annotations

import hashlib
import json
import math
import re
import tomllib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from ns_pz import __version__
from ns_pz.agents.catalog import agent_entry, is_tabular
from ns_pz.envs.registry import make_gym, spec
from ns_pz.monitor.catalog import make_monitor
from ns_pz.monitor.monitors import Monitor
from ns_pz.monitor.notification import NotificationLevel
from ns_pz.nature import (
    ContinuousScheduler,
    DiscreteScheduler,
    DistributionDecrementUpdate,
    DistributionIncrementUpdate,
    DistributionStepWiseUpdate,
    IncrementUpdate,
    ScriptedNature,
    StepWiseUpdate,
)
from ns_pz.nature.policies import Nature, StaticNature
from ns_pz.nature.schedulers import Scheduler
from ns_pz.params import SIMPLEX, Params
from ns_pz.views import NSGymEnv

SPEC_VERSION = 1
SIZES = ("quick", "full")
DETECTOR = "detector"
"""The notification column whose monitor is the spec's ``[monitor]``, not the oracle."""
LEVEL_LABELS = {"none": "WON", "basic": "basic", "detailed": "WN", DETECTOR: "WD"}
MAX_TRIALS = 1_000_000
"""Most trials one spec may hold at one size: each is a file, and the runner lists them all."""

_TOP_FIELDS = {
    "version",
    "name",
    "title",
    "env",
    "env_kwargs",
    "params",
    "notifications",
    "change",
    "sizes",
    "agents",
    "monitor",
}
_MONITOR_FIELDS = {"name", "level", "params"}
_CHANGE_FIELDS = {
    "single": {"kind", "param", "first_step", "to"},
    "continuous": {"kind", "param", "first_step", "by", "steps"},
    "none": {"kind"},
}
_SIZE_FIELDS = {"episodes", "horizon", "first_seed"}
_AGENT_FIELDS = {"name", "label", "params", "notifications", *SIZES}


class SpecError(ValueError):
    """A spec that cannot run; the message names the file and the field."""


@dataclass(frozen=True)
class Change:
    """How θ changes during an episode.

    Attributes:
        kind: ``"single"``, ``"continuous"`` or ``"none"``.
        param: The parameter that changes.
        first_step: The first transition that uses a changed θ.
        to: Single change: the value of each setting (scalar or vector, as in the file).
        by: Continuous change: what is added at each step.
        steps: Continuous change: how many steps change (``None``: every step).
    """

    kind: str
    param: str = ""
    first_step: int = 1
    to: tuple[Any, ...] = ()
    by: float = 0.0
    steps: int | None = None


_DETECTORS: dict[str, Monitor] = {}
"""The last specs' detectors (:meth:`ExperimentSpec._detector`), by what they depend on."""
_DETECTORS_KEPT = 8
"""How many bound detectors a process keeps (CliffWalking's holds about 11 MB)."""


@dataclass(frozen=True)
class MonitorSpec:
    """The monitor of the detector column.

    Attributes:
        name: A name of :mod:`ns_pz.monitor.catalog`.
        level: The notification level its messages reach the agent at.
        params: Its keyword arguments.
    """

    name: str
    level: str
    params: Mapping[str, Any]

    def make(self) -> Monitor:
        """A fresh monitor."""
        return make_monitor(self.name, self.params)


@dataclass(frozen=True)
class AgentSpec:
    """One agent of a spec, with its hyper-parameters for the chosen size."""

    name: str
    label: str
    hyper: Mapping[str, Any]
    notifications: tuple[str, ...]


@dataclass(frozen=True)
class Cell:
    """One setting × notification level: what an agent is evaluated on."""

    setting: str
    notification: str
    index: int


@dataclass(frozen=True)
class ExperimentSpec:
    """A loaded, checked spec at one size."""

    name: str
    title: str
    source: str
    size: str
    env: str
    env_kwargs: Mapping[str, Any]
    params: Mapping[str, Any]
    change: Change
    notifications: tuple[str, ...]
    agents: tuple[AgentSpec, ...]
    episodes: int
    horizon: int
    first_seed: int
    monitor: MonitorSpec | None = None

    RECORD_FIELDS: ClassVar[tuple[str, ...]] = (
        "name",
        "title",
        "size",
        "env",
        "env_kwargs",
        "params",
        "change",
        "notifications",
        "settings",
        "agents",
        "episodes",
        "horizon",
        "first_seed",
    )
    """Fields of :meth:`to_dict` that :meth:`from_dict` and the reports read."""

    # -- identity ------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """Everything that determines the results (not where the spec was read from)."""
        record = {
            "version": SPEC_VERSION,
            "ns_pz": __version__,
            "name": self.name,
            "title": self.title,
            "size": self.size,
            "env": self.env,
            "env_kwargs": dict(self.env_kwargs),
            "params": dict(self.params),
            "change": {
                "kind": self.change.kind,
                "param": self.change.param,
                "first_step": self.change.first_step,
                "to": list(self.change.to),
                "by": self.change.by,
                "steps": self.change.steps,
            },
            "notifications": list(self.notifications),
            "settings": self.settings(),
            "agents": [
                {
                    "name": a.name,
                    "label": a.label,
                    "hyper": dict(a.hyper),
                    "notifications": list(a.notifications),
                }
                for a in self.agents
            ],
            "episodes": self.episodes,
            "horizon": self.horizon,
            "first_seed": self.first_seed,
        }
        if self.monitor is not None:  # absent otherwise: older runs keep their digest
            record["monitor"] = {
                "name": self.monitor.name,
                "level": self.monitor.level,
                "params": dict(self.monitor.params),
            }
        return record

    @classmethod
    def from_dict(cls, record: Mapping[str, Any], source: str = "") -> ExperimentSpec:
        """Rebuild a spec from :meth:`to_dict` (e.g. a results directory's ``spec.json``)."""
        change = record["change"]
        monitor = record.get("monitor")
        return cls(
            name=record["name"],
            title=record["title"],
            source=source,
            size=record["size"],
            env=record["env"],
            env_kwargs=dict(record["env_kwargs"]),
            params=dict(record["params"]),
            change=Change(
                change["kind"],
                change["param"],
                change["first_step"],
                tuple(change["to"]),
                change["by"],
                change["steps"],
            ),
            notifications=tuple(record["notifications"]),
            agents=tuple(
                AgentSpec(a["name"], a["label"], dict(a["hyper"]), tuple(a["notifications"]))
                for a in record["agents"]
            ),
            episodes=record["episodes"],
            horizon=record["horizon"],
            first_seed=record["first_seed"],
            monitor=None
            if monitor is None
            else MonitorSpec(monitor["name"], monitor["level"], dict(monitor["params"])),
        )

    def digest(self) -> str:
        """A short hash of :meth:`to_dict`: equal digests mean the same experiment."""
        text = json.dumps(self.to_dict(), sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    # -- what runs -------------------------------------------------------------------------
    def settings(self) -> list[str]:
        """Labels of the settings, in order (``"p=0.4"``, ``"masspole=1"``, ``"continuous"``)."""
        if self.change.kind == "single":
            short = "p" if self._is_vector() else self.change.param
            return [f"{short}={_label_value(v)}" for v in self.change.to]
        return [self.change.kind if self.change.kind == "continuous" else "stationary"]

    def cells(self) -> list[Cell]:
        """Every setting × notification level."""
        return [
            Cell(setting, level, index)
            for index, setting in enumerate(self.settings())
            for level in self.notifications
        ]

    def trial_count(self) -> int:
        """How many trials the spec holds: each agent at each of its cells, once per seed."""
        runs = len(self.settings()) * sum(len(agent.notifications) for agent in self.agents)
        return runs * self.episodes

    def seeds(self) -> range:
        """The episode seeds of every cell (the same for all agents: common random numbers)."""
        return range(self.first_seed, self.first_seed + self.episodes)

    def theta0(self) -> Params:
        """θ_0 as a parameter set."""
        return _theta(self.env, self.params)

    def nature(self, setting_index: int) -> Nature:
        """The scripted nature of one setting."""
        change = self.change
        params_cls = spec(self.env).family.params_cls
        if change.kind == "none":
            return StaticNature()
        vector = self._is_vector()
        if change.kind == "single":
            value = _resolve_value(params_cls, change.param, change.to[setting_index])
            scheduler: Scheduler = DiscreteScheduler({change.first_step})
            if vector:
                return ScriptedNature(
                    {change.param: DistributionStepWiseUpdate(scheduler, [value])}
                )
            return ScriptedNature({change.param: StepWiseUpdate(scheduler, [value])})
        end = None if change.steps is None else change.first_step + change.steps - 1
        scheduler = ContinuousScheduler(start=change.first_step, end=end)
        if vector:
            rule = (
                DistributionIncrementUpdate(scheduler, k=change.by)
                if change.by >= 0
                else DistributionDecrementUpdate(scheduler, k=-change.by)
            )
            return ScriptedNature({change.param: rule})
        return ScriptedNature({change.param: IncrementUpdate(scheduler, k=change.by)})

    def level_of(self, notification: str) -> str:
        """The notification level of a column (the monitor's level for the detector column)."""
        if notification == DETECTOR:
            if self.monitor is None:
                raise ValueError("the detector column needs a [monitor] table")
            return self.monitor.level
        return notification

    def make_env(self, cell: Cell) -> NSGymEnv:
        """The Gymnasium view of one cell, truncating at the horizon."""
        monitor = self._detector() if cell.notification == DETECTOR else None
        return make_gym(
            self.env,
            params=self.theta0(),
            nature=self.nature(cell.index),
            notification=self.level_of(cell.notification),
            monitor=monitor,
            max_episode_steps=self.horizon,
            **self.env_kwargs,
        )

    def _detector(self) -> Monitor | None:
        """The detector column's monitor, shared in this process and bound at first use.

        Binding reads the dynamics at every point of the detector's grid (CliffWalking's
        tabular CUSUM: 53 ms, against 2 ms for the rest of a new env), and a bound monitor
        keeps no episode's state (each env keeps its own memory), so one serves every trial of
        the spec (the same family and θ_0), and of any spec with the same environment, θ_0 and
        monitor settings.
        """
        if self.monitor is None:
            return None
        # what the bound monitor depends on, not the whole spec: a spec checked without its
        # agents (load_spec's probe) or run at another size shares it
        record = self.to_dict()
        key = json.dumps(
            [record[k] for k in ("env", "env_kwargs", "params", "monitor")],
            sort_keys=True,
            separators=(",", ":"),
        )
        if key not in _DETECTORS:
            if len(_DETECTORS) >= _DETECTORS_KEPT:
                del _DETECTORS[next(iter(_DETECTORS))]  # the oldest
            _DETECTORS[key] = self.monitor.make()
        return _DETECTORS[key]

    def is_tabular(self) -> bool:
        """Whether the env hands out explicit outcome tables."""
        return is_tabular(spec(self.env).family)

    def _is_vector(self) -> bool:
        params_cls = spec(self.env).family.params_cls
        return params_cls.spec(self.change.param).kind == SIMPLEX


def slug(text: str) -> str:
    """``text`` as a file-name-safe piece of a trial key."""
    return re.sub(r"[^A-Za-z0-9.=]+", "_", text).strip("_") or "x"


def _label_value(value: Any) -> str:
    if isinstance(value, (list, tuple)):
        return "[" + ",".join(f"{v:g}" for v in value) + "]"
    return f"{value:g}"


def _resolve_value(params_cls: type[Params], name: str, value: Any) -> Any:
    """A spec value as the parameter's value: a scalar for a vector is its intended entry."""
    param = params_cls.spec(name)
    if param.kind != SIMPLEX or isinstance(value, (list, tuple)):
        return tuple(value) if isinstance(value, list) else value
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise TypeError(f"{value!r} must be a number or a list of numbers")
    rest = (1.0 - float(value)) / (param.size - 1)
    return (float(value),) + (rest,) * (param.size - 1)


def _theta(env_id: str, params: Mapping[str, Any]) -> Params:
    params_cls = spec(env_id).family.params_cls
    params_cls.check_names(params)
    return params_cls.from_mapping(
        {name: _resolve_value(params_cls, name, v) for name, v in params.items()}
    )


# -- loading ---------------------------------------------------------------------------------
def shipped_specs() -> dict[str, Path]:
    """The specs that come with ns_pz: name → file."""
    folder = resources.files("ns_pz.experiments") / "specs"
    found = {}
    for entry in folder.iterdir():
        if entry.name.endswith(".toml"):
            found[entry.name.removesuffix(".toml")] = Path(str(entry))
    return dict(sorted(found.items()))


def resolve_spec_path(name_or_path: str) -> Path:
    """A shipped spec's file by name, or the file at a path.

    Raises:
        SpecError: Neither a shipped spec nor an existing file.
    """
    shipped = shipped_specs()
    if name_or_path in shipped:
        return shipped[name_or_path]
    path = Path(name_or_path)
    if path.is_file():
        return path
    raise SpecError(
        f"spec {name_or_path!r} is neither a shipped spec nor a file; shipped: {', '.join(shipped)}"
    )


def load_spec(name_or_path: str | Path, size: str = "quick") -> ExperimentSpec:
    """Read and check a spec at ``size`` (``"quick"`` or ``"full"``).

    Raises:
        SpecError: Anything wrong, naming the file and field, before anything runs.
    """
    path = resolve_spec_path(str(name_or_path))
    if size not in SIZES:
        raise SpecError(f"size={size!r}; allowed: {', '.join(SIZES)}")
    try:
        raw = tomllib.loads(path.read_text(encoding="utf-8"))
    except UnicodeDecodeError as error:
        raise SpecError(f"{path}: not UTF-8 text, as TOML must be: {error}") from None
    except tomllib.TOMLDecodeError as error:
        raise SpecError(f"{path}: not valid TOML: {error}") from None
    return _Checker(path).spec(raw, size)


class _Checker:
    """Turns the raw TOML of one file into an :class:`ExperimentSpec`, or a :class:`SpecError`."""

    def __init__(self, path: Path) -> None:
        self.path = path

    def fail(self, field: str, problem: str) -> SpecError:
        return SpecError(f"{self.path}: {field}: {problem}")

    def fields(self, where: str, table: Any, allowed: set[str], required: set[str]) -> None:
        if not isinstance(table, Mapping):
            raise self.fail(where, f"must be a table, got {table!r}")
        for key in table:
            if key not in allowed:
                raise self.fail(
                    f"{where}.{key}" if where else key,
                    f"unknown field; allowed: {', '.join(sorted(allowed))}",
                )
        for key in sorted(required - set(table)):
            raise self.fail(f"{where}.{key}" if where else key, "missing")

    def data(self, field: str, value: Any) -> None:
        """Refuse what a result record cannot hold, naming the key: NaN, an infinity, a date.

        Raises:
            SpecError: The first such value, with its key under ``field``.
        """
        if isinstance(value, Mapping):
            for key, item in value.items():
                self.data(f"{field}.{key}", item)
        elif isinstance(value, list):
            for i, item in enumerate(value):
                self.data(f"{field}[{i}]", item)
        elif isinstance(value, float) and not math.isfinite(value):
            raise self.fail(field, f"{value!r} must be a finite number")
        elif not isinstance(value, (str, int, float, bool)):
            raise self.fail(
                field,
                f"{value!r} ({type(value).__name__}) must be a number, string, boolean, or a "
                "list or table of them",
            )

    def integer(self, field: str, value: Any, low: int) -> int:
        if isinstance(value, bool) or not isinstance(value, int) or value < low:
            raise self.fail(field, f"{value!r} must be an integer >= {low}")
        return value

    def spec(self, raw: Mapping[str, Any], size: str) -> ExperimentSpec:
        required = {"version", "name", "env", "change", "sizes", "agents"}
        self.fields("", raw, _TOP_FIELDS, required)
        if raw["version"] != SPEC_VERSION:
            raise self.fail(
                "version", f"{raw['version']!r}; this ns_pz reads version {SPEC_VERSION}"
            )
        name = raw["name"]
        if not isinstance(name, str) or not re.fullmatch(r"[A-Za-z0-9][A-Za-z0-9._-]*", name):
            raise self.fail(
                "name", f"{name!r} must be letters, digits, '.', '_' or '-' (it names a folder)"
            )
        env_id = self.env(raw["env"])
        env_kwargs = raw.get("env_kwargs", {})
        self.fields("env_kwargs", env_kwargs, set(env_kwargs), set())
        self.data("env_kwargs", env_kwargs)
        params = raw.get("params", {})
        self.fields("params", params, set(params), set())
        try:
            _theta(env_id, params)
        except (TypeError, ValueError) as error:
            raise self.fail("params", str(error)) from None
        notifications = self.levels(
            "notifications", raw.get("notifications", ["none"]), detector=True
        )
        monitor = self.monitor(raw.get("monitor"), notifications)
        change = self.change(raw["change"], env_id, params)
        sizes = raw["sizes"]
        self.fields("sizes", sizes, set(SIZES), set())
        if size not in sizes:
            raise self.fail("sizes", f"has no {size!r} size; it has: {', '.join(sizes)}")
        for each in sizes:  # every size is checked, not only the one that runs now
            self.fields(f"sizes.{each}", sizes[each], _SIZE_FIELDS, {"episodes", "horizon"})
            self.integer(f"sizes.{each}.episodes", sizes[each]["episodes"], 1)
            each_horizon = self.integer(f"sizes.{each}.horizon", sizes[each]["horizon"], 1)
            self.integer(f"sizes.{each}.first_seed", sizes[each].get("first_seed", 0), 0)
            if change.kind != "none" and change.first_step >= each_horizon:
                raise self.fail(
                    "change.first_step",
                    f"{change.first_step} is not before sizes.{each}.horizon = {each_horizon}: "
                    "no change would ever happen",
                )
        episodes = sizes[size]["episodes"]
        horizon = sizes[size]["horizon"]
        first_seed = sizes[size].get("first_seed", 0)
        agents = raw["agents"]
        if not isinstance(agents, list) or not agents:
            raise self.fail("agents", "must be a non-empty array of tables ([[agents]])")
        result = ExperimentSpec(
            name=name,
            title=str(raw.get("title", name)),
            source=str(self.path),
            size=size,
            env=env_id,
            env_kwargs=dict(env_kwargs),
            params=dict(params),
            change=change,
            notifications=notifications,
            agents=(),
            episodes=episodes,
            horizon=horizon,
            first_seed=first_seed,
            monitor=monitor,
        )
        try:
            probe_env = result.make_env(result.cells()[0])
        except (TypeError, ValueError) as error:
            raise self.fail("env_kwargs", str(error)) from None
        if monitor is not None:
            try:
                result.make_env(Cell(result.settings()[0], DETECTOR, 0))
            except (TypeError, ValueError) as error:
                raise self.fail("monitor", f"cannot watch {env_id}: {error}") from None
        checked = tuple(
            self.agent(f"agents[{i}]", a, size, notifications, probe_env, result.level_of)
            for i, a in enumerate(agents)
        )
        keys = [slug(a.label) for a in checked]
        for agent, key in zip(checked, keys, strict=True):
            if keys.count(key) > 1:
                raise self.fail(
                    "agents",
                    f"two agents are labelled {agent.label!r} (or labels that differ only in "
                    "punctuation); give each a distinct label",
                )
        settings = result.settings()
        for setting in settings:
            if settings.count(setting) > 1:
                raise self.fail("change.to", f"two settings are both labelled {setting!r}")
        runs = len(settings) * sum(len(agent.notifications) for agent in checked)
        for each in sizes:
            trials = runs * sizes[each]["episodes"]
            if trials > MAX_TRIALS:
                raise self.fail(
                    f"sizes.{each}.episodes",
                    f"{sizes[each]['episodes']} episodes give {trials} trials ({runs} agent × "
                    f"cell runs); a run stores one file per trial and takes at most "
                    f"{MAX_TRIALS}: split it into several specs or use fewer episodes",
                )
        return ExperimentSpec(**{**result.__dict__, "agents": checked})

    def env(self, env_id: Any) -> str:
        if not isinstance(env_id, str):
            raise self.fail("env", f"{env_id!r} must be a registered env id (a string)")
        try:
            spec(env_id)
        except ValueError as error:
            raise self.fail("env", str(error)) from None
        return env_id

    def levels(self, field: str, levels: Any, detector: bool = False) -> tuple[str, ...]:
        allowed = [level.value for level in NotificationLevel] + ([DETECTOR] if detector else [])
        if not isinstance(levels, (list, tuple)) or not levels:
            raise self.fail(field, f"{levels!r} must be a non-empty list of {allowed}")
        for level in levels:
            if level not in allowed:
                raise self.fail(
                    field, f"{level!r} is not a notification level; allowed: {', '.join(allowed)}"
                )
        if len(set(levels)) != len(levels):
            raise self.fail(field, f"{levels!r} lists a level twice")
        return tuple(levels)

    def monitor(self, raw: Any, notifications: Sequence[str]) -> MonitorSpec | None:
        if raw is None:
            if DETECTOR in notifications:
                raise self.fail(
                    "notifications", f"{DETECTOR!r} needs a [monitor] table naming the detector"
                )
            return None
        self.fields("monitor", raw, _MONITOR_FIELDS, {"name"})
        if DETECTOR not in notifications:
            raise self.fail("monitor", f"is given but notifications has no {DETECTOR!r} column")
        level = raw.get("level", "detailed")
        allowed = [level.value for level in NotificationLevel if level.shows_flags]
        if level not in allowed:
            raise self.fail(
                "monitor.level",
                f"{level!r}; allowed: {', '.join(allowed)} (at 'none' the agent hears nothing)",
            )
        params = raw.get("params", {})
        self.fields("monitor.params", params, set(params), set())
        self.data("monitor.params", params)
        try:
            make_monitor(raw["name"], params)
        except (TypeError, ValueError) as error:
            raise self.fail("monitor", str(error)) from None
        return MonitorSpec(raw["name"], level, dict(params))

    def change(self, raw: Any, env_id: str, params: Mapping[str, Any]) -> Change:
        if not isinstance(raw, Mapping) or raw.get("kind") not in _CHANGE_FIELDS:
            kind = raw.get("kind") if isinstance(raw, Mapping) else raw
            raise self.fail("change.kind", f"{kind!r}; allowed: {', '.join(_CHANGE_FIELDS)}")
        kind = raw["kind"]
        required = {"kind"} if kind == "none" else {"kind", "param", "first_step"}
        required |= {"to"} if kind == "single" else {"by"} if kind == "continuous" else set()
        self.fields("change", raw, _CHANGE_FIELDS[kind], required)
        if kind == "none":
            return Change("none")
        params_cls = spec(env_id).family.params_cls
        name = raw["param"]
        try:
            params_cls.check_names([name])
        except ValueError as error:
            raise self.fail("change.param", str(error)) from None
        first_step = self.integer("change.first_step", raw["first_step"], 0)
        if kind == "single":
            values = raw["to"]
            if not isinstance(values, list) or not values:
                raise self.fail("change.to", f"{values!r} must be a non-empty list of values")
            for i, value in enumerate(values):
                try:
                    _theta(env_id, {**params, name: value})
                except (TypeError, ValueError) as error:
                    raise self.fail(f"change.to[{i}]", str(error)) from None
            return Change(kind, name, first_step, to=tuple(values))
        by = raw["by"]
        if (
            isinstance(by, bool)
            or not isinstance(by, (int, float))
            or not math.isfinite(by)
            or by == 0
        ):
            raise self.fail("change.by", f"{by!r} must be a finite, non-zero number")
        steps = raw.get("steps")
        if steps is not None:
            steps = self.integer("change.steps", steps, 1)
        return Change(kind, name, first_step, by=float(by), steps=steps)

    def agent(
        self,
        where: str,
        raw: Any,
        size: str,
        levels: Sequence[str],
        probe_env: NSGymEnv,
        level_of: Callable[[str], str],
    ) -> AgentSpec:
        self.fields(where, raw, _AGENT_FIELDS, {"name"})
        try:
            entry = agent_entry(raw["name"])
        except ValueError as error:
            raise self.fail(f"{where}.name", str(error)) from None
        common = raw.get("params", {})
        self.fields(f"{where}.params", common, set(common), set())
        for field in ("params", *SIZES):  # each table on its own, every size
            table = raw.get(field, {})
            self.fields(f"{where}.{field}", table, set(table), set())
            try:
                entry.check_names(table)
            except ValueError as error:
                raise self.fail(f"{where}.{field}", str(error)) from None
        for table_name in ("params", *SIZES):  # every size, not only the one that runs now
            self.data(f"{where}.{table_name}", raw.get(table_name, {}))
        hyper = _merged(common, raw.get(size, {}))
        if entry.tabular_only and not is_tabular(probe_env.family):
            raise self.fail(
                f"{where}.name",
                f"agent {entry.name!r} plans on an explicit outcome table, which "
                f"{probe_env.family!r} cannot give; use it on a tabular env (FrozenLake, "
                "CliffWalking, Bridge)",
            )
        default_levels = [level for level in levels if level_of(level) in entry.levels]
        if not default_levels:
            raise self.fail(
                f"{where}.name",
                f"agent {entry.name!r} runs at {sorted(entry.levels)} only; the spec has "
                f"{list(levels)}",
            )
        agent_levels = self.levels(
            f"{where}.notifications", raw.get("notifications", default_levels), detector=True
        )
        for level in agent_levels:
            if level not in levels:
                raise self.fail(
                    f"{where}.notifications",
                    f"{level!r} is not among the spec's notifications {list(levels)}",
                )
            if level_of(level) not in entry.levels:
                raise self.fail(
                    f"{where}.notifications",
                    f"agent {entry.name!r} runs at {sorted(entry.levels)} only, not {level!r}",
                )
        for other in SIZES:  # the other sizes' values too, built but not played
            if other != size:
                self.try_build(where, entry, common, raw.get(other, {}), other, probe_env)
        agent = self.try_build(where, entry, common, raw.get(size, {}), size, probe_env)
        if agent is not None:
            self.try_acting(where, entry, agent, probe_env)
        label = raw.get("label", entry.name)
        if not isinstance(label, str) or not label:
            raise self.fail(f"{where}.label", f"{label!r} must be a non-empty string")
        resolved = {**entry.defaults(), **hyper}
        try:
            json.dumps(resolved, allow_nan=False)
        except (TypeError, ValueError):
            resolved = dict(hyper)  # a default that is not data (a callable): record the given
        return AgentSpec(entry.name, label, resolved, agent_levels)

    def try_build(
        self,
        where: str,
        entry: Any,
        common: Mapping[str, Any],
        sized: Mapping[str, Any],
        size: str,
        env: NSGymEnv,
    ) -> Any:
        """The agent of ``size``'s hyper-parameters, built on ``env`` (None for a learner).

        An agent that needs trained networks is only checked for its hyper-parameters: building
        it would train them, which the runner does once before the trials. A bad value is
        blamed on the table that holds it: ``params`` when the common values alone fail alike.
        """
        try:
            return _built(entry, _merged(common, sized), env)
        except (TypeError, ValueError) as error:
            field = f"{where}.{size}" if sized else f"{where}.params"
            if sized:
                try:
                    _built(entry, dict(common), env)
                except (TypeError, ValueError) as alone:
                    if str(alone) == str(error):  # the common value, not overridden, fails
                        field = f"{where}.params"
            raise self.fail(field, str(error)) from None

    def try_acting(self, where: str, entry: Any, agent: Any, env: NSGymEnv) -> None:
        """Let ``agent`` act once on ``env``, so an agent that cannot run here fails now."""
        try:
            observation, _ = env.reset(seed=0)
            agent.reset(np.random.default_rng(0))
            agent.act(observation, env.planning_model() if agent.needs_model else None)
        except Exception as error:  # noqa: BLE001 - any failure means it cannot run here
            raise self.fail(
                f"{where}.name",
                f"agent {entry.name!r} cannot act in {env.family!r}: "
                f"{type(error).__name__}: {error}",
            ) from None


def _built(entry: Any, hyper: Mapping[str, Any], env: NSGymEnv) -> Any:
    """``entry``'s agent on ``env``, or None after checking a learner's networks' settings."""
    if entry.artefacts is not None:
        entry.artefacts(env, hyper)
        return None
    return entry.make(env, hyper)


def _merged(common: Mapping[str, Any], sized: Mapping[str, Any]) -> dict[str, Any]:
    """``common`` overridden by a size's table, nested tables merged key by key.

    ``params = { ddqn = { hidden = [32] } }`` and ``quick = { ddqn = { total_steps = 1000 } }``
    give ``ddqn = { hidden = [32], total_steps = 1000 }`` at the quick size.
    """
    merged = dict(common)
    for key, value in sized.items():
        base = merged.get(key)
        if isinstance(base, Mapping) and isinstance(value, Mapping):
            merged[key] = _merged(base, value)
        else:
            merged[key] = value
    return merged
