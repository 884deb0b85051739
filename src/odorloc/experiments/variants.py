"""Sweeps over settings a grid cannot express.

A paper's point often changes several scenario fields at once (a larger search area moves the
arena's corner, the source and the start positions together), which a sweep's grid of single
fields cannot say, and a setting of the searcher (a particle count) needs only one world, which
crossing it with every world would waste.

- :class:`Sweep` sets one field of a paper's point (a frozen dataclass) to each of its values;
  :func:`restrict` cuts sweeps to chosen values;
- a :class:`WorldVariant` is a labelled set of dotted scenario overrides, and
  :func:`variant_sweeps` turns worlds x searchers, plus searcher variants on the base world,
  into sweep dictionaries for :func:`~odorloc.experiments.sweep.load_sweep`.

Every variant of one world shares its world key (the scenario name and the variant's suffix),
so episode ``i`` of every searcher there faces the same world (common random numbers); the
base world's key is the scenario name itself, so ``odorloc run SCENARIO --episode I`` replays
its episode ``I``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

from odorloc.core.errors import ConfigError

__all__ = ["Sweep", "WorldVariant", "restrict", "variant_sweeps"]


@dataclass(frozen=True)
class WorldVariant:
    """One world of a reproduction.

    Attributes
    ----------
    suffix : str
        Appended to the scenario name to make the world key (``""``: the base world).
    params : mapping of str to value
        Dotted scenario overrides giving this world.
    """

    suffix: str = ""
    params: Mapping[str, Any] = field(default_factory=dict)


def variant_sweeps(
    scenario: str,
    worlds: Sequence[WorldVariant],
    searchers: Sequence[Mapping[str, Any]],
    episodes: int,
    seed: int,
    *,
    base_searchers: Sequence[Mapping[str, Any]] = (),
    base_part: str = "base",
    replay: bool = False,
    common: Mapping[str, Any] | None = None,
    name: str = "sweep",
) -> dict[str, dict[str, Any]]:
    """Sweep dictionaries: ``{"": every world x searchers, base_part: the base world x
    base_searchers}`` (the second only when there are base searchers).

    Parameters
    ----------
    scenario : str
        The base scenario.
    worlds : sequence of WorldVariant
        The worlds (duplicates are run once).
    searchers, base_searchers : sequence of dict
        Sweep searcher entries (``{"name": ..., "label": ..., "params": ...}``).
    episodes, seed : int
    replay : bool
        Record each world's flow once per episode and replay it to every searcher.
    common : mapping, optional
        Overrides applied to every world (e.g. a shorter time limit in tests).
    name : str
        Name of the sweeps.
    """
    seen: list[WorldVariant] = []
    for w in worlds:
        if w not in seen:
            seen.append(w)
    extra = dict(common or {})

    def entry(w: WorldVariant) -> dict[str, Any]:
        e: dict[str, Any] = {"name": scenario, "params": {**w.params, **extra}}
        if w.suffix:
            e["label"] = f"{scenario}{w.suffix}"
        return e

    def head(tag: str) -> dict[str, Any]:
        return {"name": f"{name} {tag}", "seed": seed, "episodes": episodes, "replay": replay}

    out = {
        "": {
            **head("worlds"),
            "scenarios": [entry(w) for w in seen],
            "searchers": [dict(s) for s in searchers],
        }
    }
    if base_searchers:
        out[base_part] = {
            **head(base_part),
            "scenarios": [entry(WorldVariant())],
            "searchers": [dict(s) for s in base_searchers],
        }
    return out


@dataclass(frozen=True)
class Sweep:
    """One swept parameter of a paper: its values, set on a base point (a frozen dataclass).

    Attributes
    ----------
    key : str
        The sweep's name (e.g. ``uavs``).
    figure : str
        The paper's figure.
    xlabel : str
    values : tuple
        The swept values.
    base : Any
        The point the other parameters come from (a frozen dataclass instance).
    field : str
        The field of ``base`` the values set.
    """

    key: str
    figure: str
    xlabel: str
    values: tuple[Any, ...]
    base: Any
    field: str

    def setting(self, value: Any) -> Any:
        """The point of one swept value."""
        return replace(self.base, **{self.field: value})

    def settings(self) -> list[Any]:
        """Every swept point, in order."""
        return [self.setting(v) for v in self.values]

    def tick(self, value: Any) -> str:
        """The x tick of a value (``x``-joined numbers for a tuple)."""
        if isinstance(value, tuple):
            return "x".join(f"{v:g}" for v in value)
        return f"{value:g}"


def restrict(
    sweeps: Sequence[Sweep], values: Mapping[str, Sequence[Any]] | None, strict: bool = True
) -> list[Sweep]:
    """``sweeps`` cut to ``values`` (sweep key -> values to keep; a sweep without any is left
    out; ``None`` keeps everything). A value given as a list stands for a tuple (YAML, JSON).
    ``strict=False`` leaves out the values a sweep lacks (a second set of sweeps with fewer
    values, cut by the values checked against the first).

    Raises
    ------
    ConfigError
        Naming ``values`` for an unknown key, ``values.<key>`` for a value the sweep lacks
        (``strict`` only).
    """
    if values is None:
        return list(sweeps)
    known = {sw.key: sw for sw in sweeps}
    if not isinstance(values, Mapping):
        raise ConfigError("values", f"must map sweep keys to values, got {values!r}")
    keep: dict[str, tuple[Any, ...]] = {}
    for key, given in values.items():
        if key not in known:
            raise ConfigError("values", f"unknown sweep key {key!r} (known: {', '.join(known)})")
        if isinstance(given, str) or not isinstance(given, Sequence):
            raise ConfigError(f"values.{key}", f"must be a list of values, got {given!r}")
        keep[key] = tuple(tuple(v) if isinstance(v, list) else v for v in given)
        for v in keep[key]:
            if strict and v not in known[key].values:
                ticks = ", ".join(known[key].tick(k) for k in known[key].values)
                raise ConfigError(
                    f"values.{key}", f"{v!r} is not a value of the sweep (known: {ticks})"
                )
    out = []
    for sw in sweeps:
        kept = tuple(v for v in sw.values if v in keep.get(sw.key, ()))
        if kept:
            out.append(replace(sw, values=kept))
    return out
