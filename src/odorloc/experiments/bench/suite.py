"""The benchmark suite: versioned tasks (data shipped with the package) and the methods that
can run each of them.

A suite file (``suite-<version>.yaml`` beside this module) names its version, a root seed, its
tiers, the registered searchers that are not methods on their own (``exclude``, with a reason
each), what some methods need of a task (``requires``: the platform a method is built for) and
its tasks. A task is a built-in scenario with a fixed episode count per tier, a rank
criterion, the metrics it adds, the settings it tells every method (``knowledge``), the methods
it cannot judge (its own ``exclude``) and scenario overrides per tier (``params``).

Methods of a task (:func:`task_methods`): every registered searcher the scenario builder accepts
on the task's scenario (its dimensions, agent counts, whether it declares where the task needs
declarations: :func:`odorloc.scenarios.loading.check_scenario`), less the excluded ones, plus
the methods a user adds by import path (``mypkg.module:MySearcher``) or as a YAML preset.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any, Literal

import pydantic
from pydantic import Field, model_validator

from odorloc.core.errors import ConfigError, format_validation_error
from odorloc.core.loading import load_yaml_mapping
from odorloc.core.params import Params, Seed

__all__ = [
    "DEFAULT_SUITE",
    "TIERS",
    "Method",
    "Suite",
    "Task",
    "load_suite",
    "method_from_option",
    "task_methods",
]

#: The suite ``odorloc bench`` runs unless told otherwise.
DEFAULT_SUITE = "2027.1"

TIERS = ("quick", "standard")
Tier = Literal["quick", "standard"]

#: Metrics a task may add to the board beside the common ones.
TASK_METRICS = ("energy", "bytes", "emd", "rate_error")


class TierSpec(Params):
    """A tier: its wall-time budget on two cores (s) and what it is for."""

    budget_s: float = Field(gt=0)
    summary: str = ""


class Task(Params):
    """One task of the suite.

    Parameters
    ----------
    name : str
        The task's name on the board.
    scenario : str
        Built-in scenario.
    summary, rule : str
        What the world is and what counts as a success (the scenario's ``task`` section says
        it for the engine; this is its text for the board).
    rank_by : {"success", "search_time"}
        Rank criterion: the success rate (higher first, Wilson intervals) or the mean search
        time of the successes (lower first, bootstrap intervals; the lattice problem, where
        nearly every search succeeds and OTTO reports mean moves).
    metrics : list of str
        Extra metrics of the task: ``energy`` (J), ``bytes`` (radio bytes), ``emd`` (Earth
        Mover's Distance of the declared set to the sources, m), ``rate_error`` (factor between
        the estimated and the true release rate).
    knowledge : dict
        Searcher parameters every method whose parameters have the field receives.
    exclude : dict of str
        Method -> why the task cannot judge it.
    episodes : dict
        Episodes per method, per tier.
    params : dict
        Tier -> scenario overrides (dotted keys) of that tier only.
    reference : dict, optional
        Published numbers the task's rows are checked against: ``source`` (the citation) and
        ``search_time`` (method -> ``[mean, standard error]``, s).
    """

    name: str = Field(min_length=1, pattern=r"^[a-z0-9][a-z0-9._-]*$")
    scenario: str = Field(min_length=1)
    summary: str = ""
    rule: str = ""
    rank_by: Literal["success", "search_time"] = "success"
    metrics: list[Literal["energy", "bytes", "emd", "rate_error"]] = Field(default_factory=list)
    knowledge: dict[str, Any] = Field(default_factory=dict)
    exclude: dict[str, str] = Field(default_factory=dict)
    episodes: dict[Tier, int] = Field(min_length=2)
    params: dict[Tier, dict[str, Any]] = Field(default_factory=dict)
    reference: dict[str, Any] | None = None

    @model_validator(mode="after")
    def _counts(self) -> Task:
        for tier in TIERS:
            n = self.episodes.get(tier)
            if n is None or n < 1:
                raise ValueError(f"episodes.{tier} must be a positive count")
        return self

    def overrides(self, tier: str) -> dict[str, Any]:
        """Scenario overrides of ``tier``."""
        return dict(self.params.get(tier, {}))  # type: ignore[call-overload]


class Suite(Params):
    """A versioned suite (module docstring)."""

    suite: str = Field(min_length=1)
    seed: Seed
    tiers: dict[Tier, TierSpec]
    exclude: dict[str, str] = Field(default_factory=dict)
    requires: dict[str, dict[Literal["platform"], str]] = Field(default_factory=dict)
    tasks: list[Task] = Field(min_length=1)

    @model_validator(mode="after")
    def _distinct(self) -> Suite:
        names = [t.name for t in self.tasks]
        for i, n in enumerate(names):
            if n in names[:i]:
                raise ValueError(f"task {n!r} is defined twice")
        return self

    def task(self, name: str) -> Task:
        """The task called ``name`` (:class:`ConfigError` naming ``--tasks`` otherwise)."""
        for t in self.tasks:
            if t.name == name:
                return t
        known = ", ".join(t.name for t in self.tasks)
        raise ConfigError("--tasks", f"unknown task {name!r} (suite {self.suite}: {known})")

    def select(self, names: Sequence[str] | None) -> list[Task]:
        """The tasks named (all when ``names`` is empty), in the suite's order."""
        if not names:
            return list(self.tasks)
        wanted = {self.task(n).name for n in names}
        return [t for t in self.tasks if t.name in wanted]


def _suite_file(version: str) -> Path:
    return Path(str(resources.files("odorloc.experiments.bench"))) / f"suite-{version}.yaml"


def suite_versions() -> list[str]:
    """The suite versions shipped with the package."""
    folder = Path(str(resources.files("odorloc.experiments.bench")))
    return sorted(p.stem.removeprefix("suite-") for p in folder.glob("suite-*.yaml"))


def load_suite(source: str | Path | Mapping[str, Any] = DEFAULT_SUITE) -> Suite:
    """A suite by version (``"2027.1"``), from a file, or from a mapping.

    Raises
    ------
    ConfigError
        ``--suite`` for an unknown version; the first invalid field otherwise.
    """
    if isinstance(source, Mapping):
        data: Any = dict(source)
    else:
        text = str(source)
        path = Path(text)
        if text in suite_versions():
            path = _suite_file(text)
        elif path.suffix.lower() not in (".yaml", ".yml"):
            known = ", ".join(suite_versions())
            raise ConfigError("--suite", f"unknown suite version {text!r} (known: {known})")
        data = load_yaml_mapping(path, "suite")
    try:
        return Suite.model_validate(data)
    except pydantic.ValidationError as err:
        line = format_validation_error(err, model=Suite)
        fld, _, problem = line.partition(": ")
        raise ConfigError(f"suite.{fld}".replace(".[", "["), problem) from None


# ----------------------------------------------------------------------------- methods


@dataclass(frozen=True)
class Method:
    """A method on the board.

    Parameters
    ----------
    name : str
        Its row label.
    searcher : str
        Registry name, ``module:Class`` or the name a YAML preset registered.
    params : dict
        Its own parameters (a preset's are inside its registration).
    source : {"registry", "import", "preset"}
        Where it came from.
    """

    name: str
    searcher: str
    params: dict[str, Any] = field(default_factory=dict)
    source: str = "registry"


def method_from_option(text: str) -> Method:
    """A method given on the command line: a registered name, ``package.module:Class`` (a
    searcher class carrying its ``Params``), or a YAML preset file (``name``, ``base``,
    ``params``: it runs as its base with those settings). ``LABEL=...`` names its row (a new
    version of a method compared with the board's row of that name).

    Raises
    ------
    ConfigError
        ``--method`` naming what is wrong.
    """
    from odorloc.core import registry

    label, eq, spec = text.partition("=")
    if eq:
        if not label.strip() or not spec.strip():
            raise ConfigError("--method", f"expected LABEL=METHOD, got {text!r}")
        m = method_from_option(spec.strip())
        return Method(label.strip(), m.searcher, m.params, m.source)
    if text.endswith((".yaml", ".yml")):
        # a preset runs as its base with its settings, so worker processes need no registration
        data = load_yaml_mapping(Path(text), "--method")
        unknown = sorted(set(data) - {"name", "base", "summary", "params"})
        if unknown:
            raise ConfigError("--method", f"{text}: unknown keys {unknown}")
        if "name" not in data or "base" not in data:
            raise ConfigError("--method", f"{text}: a preset needs 'name' and 'base'")
        params = data.get("params") or {}
        if not isinstance(params, dict):
            raise ConfigError("--method", f"{text}: 'params' must be a mapping of settings")
        base = str(data["base"])
        registry.entry("searcher", base, field="--method")
        return Method(name=str(data["name"]), searcher=base, params=params, source="preset")
    if ":" in text:
        registry.entry("searcher", text, field="--method")
        return Method(name=text.rsplit(":", 1)[1], searcher=text, source="import")
    if text not in registry.names("searcher"):
        raise ConfigError("--method", f"unknown searcher {text!r} (odorloc components searcher)")
    return Method(name=text, searcher=text)


def _accepts(searcher: str) -> set[str]:
    """The parameter fields of a searcher (what ``knowledge`` may set)."""
    from odorloc.core import registry

    params = registry.entry("searcher", searcher).params
    return set(params.model_fields) if params is not None else set()


def method_cell(task: Task, method: Method, own: str) -> dict[str, Any]:
    """The sweep entry of ``method`` on ``task`` (``own``: the scenario's own searcher type):
    its parameters over the task's knowledge where its parameters have those fields."""
    known = {k: v for k, v in task.knowledge.items() if k in _accepts(method.searcher)}
    params = {**known, **method.params}
    entry: dict[str, Any] = {"name": method.searcher, "label": method.name}
    if params:
        entry["params"] = params
    return entry


@dataclass
class Applicability:
    """Which methods a task runs, and why the others do not."""

    methods: list[Method]
    skipped: dict[str, str]


def task_methods(
    suite: Suite,
    task: Task,
    methods: Sequence[Method] | None = None,
    extra: Sequence[Method] = (),
) -> Applicability:
    """The methods of ``task`` (module docstring): ``methods`` (default: every registered
    searcher) that the scenario accepts and neither the suite nor the task excludes, then the
    user's ``extra`` methods that the scenario accepts. A method a task cannot run is kept in
    ``skipped`` with the builder's one-line reason."""
    from odorloc.core import registry
    from odorloc.experiments.runner import cell_scenario
    from odorloc.scenarios import get_scenario
    from odorloc.scenarios.loading import check_scenario

    base = get_scenario(task.scenario)
    own = base.searcher.type
    platform = base.platform.type
    if methods is None:
        methods = [Method(n, n) for n in registry.names("searcher")]
    chosen: list[Method] = []
    skipped: dict[str, str] = {}
    world: Any = None
    for m in [*methods, *extra]:
        if m.source == "registry" and m.searcher != own:
            why = task.exclude.get(m.searcher) or suite.exclude.get(m.searcher)
            if why:
                skipped[m.name] = why
                continue
        need = suite.requires.get(m.searcher, {}).get("platform")
        if need is not None and need != platform:
            skipped[m.name] = f"needs a {need} platform (the task's is {platform})"
            continue
        entry = method_cell(task, m, own)
        cell = {
            "scenario": task.scenario,
            "searcher": m.searcher,
            "searcher_params": entry.get("params", {}),
            "overrides": task.overrides("standard"),
        }
        try:
            world = check_scenario(cell_scenario(cell), world)
        except ConfigError as exc:
            skipped[m.name] = f"{exc.field}: {exc.problem}"
            continue
        chosen.append(m)
    return Applicability(chosen, skipped)
