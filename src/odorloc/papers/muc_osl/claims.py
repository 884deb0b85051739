"""The multi-UAV paper's statements (Sect. VI), each tested on the reproduction's episodes.

Every statement is turned into a quantity with a 95 % bootstrap interval (see
:mod:`~odorloc.papers.muc_osl.analysis`) and a verdict: *held* when the interval lies on the
claimed side, *not held* when it lies on the other, *undecided* otherwise. A statement about
several algorithms or points holds when every part does and fails when any part fails.

=====================================================  ==========================================
statement (paper)                                      quantity
=====================================================  ==========================================
MUC-OSL has the highest SR / lowest MST at every       paired differences MUC-OSL - baseline at
point of every sweep                                   every (distinct) point, every baseline
SR rises and MST falls with more UAVs / particles      least-squares slope over all episodes
... flattening beyond ~5 UAVs / ~160 particles         slope below the knee minus slope above
Col-PF depends on the radius more than Adap-PP         slope of SR (and MST) on the radius,
                                                       Col-PF minus Adap-PP (paired)
Col-PF is worse than Adap-PP at small radii            paired difference over 0, 5 and 10 m
Col-Inf degrades most with the area                    drop of SR (rise of MST) from the smallest
                                                       to the largest area, Col-Inf minus the
                                                       largest of the others
Col-Inf fails at 100x200x50 m                          its successes there (none: held)
MUC-OSL still succeeds there (paper 24 %)              its success rate (above 0: held; below
                                                       24 % for sure: not held)
MUC-OSL's E_M is below Col-Inf's (-8.44 %)             paired relative difference of the means
... with fewer hover and turning points                paired differences of hover and turn time
without eq. 16 (ablation, default point): MUC-OSL      the same three quantities for the ablation
best SR and MST; E_M below Col-Inf's                   ``muc-osl-no-env-pu`` (both worlds)
filament world: ~90 % SR at 8 min (100x60x30)          MUC-OSL's SR at 8 min vs 75 %
... > 80 % at 8 min with more than 3 UAVs              MUC-OSL's SR at 8 min (5, 8 UAVs) vs 80 %
... MUC-OSL the best at every Fig. 9 setting           as the first row, filament world
... same or better than the rate world                 SR difference filament - rate (MUC-OSL)
=====================================================  ==========================================
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from odorloc.experiments import stats
from odorloc.papers.muc_osl.analysis import Cells, bootstrap, combine, slope, verdict
from odorloc.papers.muc_osl.reference import (
    ALGORITHMS,
    ENERGY_SAVING,
    FILAMENT_AT,
    FILAMENT_SUCCESS_8MIN,
    FILAMENT_SUCCESS_8MIN_MANY_UAVS,
    LARGEST_AREA_SUCCESS,
)
from odorloc.papers.muc_osl.sweeps import DEFAULT, NO_ENV_PU, Setting, SweepDef, cell_of

__all__ = ["Claim", "evaluate_claims"]

#: "In the ballpark" of a success rate: at least this fraction of it (about 90 % -> 75 %).
BALLPARK = 5.0 / 6.0

LABELS = {
    "muc-osl": "MUC-OSL",
    "col-inf": "Col-Inf",
    "col-pf": "Col-PF",
    "adap-pp": "Adap-PP",
    NO_ENV_PU: "MUC-OSL without eq. 16",
}


@dataclass(frozen=True)
class Claim:
    """One statement of the paper and what the reproduction shows.

    Attributes
    ----------
    world : str
        ``rate`` or ``filament``.
    statement : str
    paper : str
        The paper's figure or number.
    ours : str
        Our quantity with its interval.
    verdict : str
        ``held``, ``not held`` or ``undecided``.
    """

    world: str
    statement: str
    paper: str
    ours: str
    verdict: str

    def row(self) -> list[str]:
        """The claim as a table row."""
        return [self.world, self.statement, self.paper, self.ours, self.verdict]


def _ci_text(v: float, lo: float, hi: float, scale: float = 1.0, digits: int = 0) -> str:
    if math.isnan(v):
        return "-"
    return f"{v * scale:+.{digits}f} [{lo * scale:+.{digits}f}, {hi * scale:+.{digits}f}]"


def _pct(k: int, n: int) -> str:
    if n == 0:
        return "-"
    lo, hi = stats.wilson_interval(k, n)
    return f"{100 * k / n:.0f} % [{100 * lo:.0f}, {100 * hi:.0f}] ({k}/{n})"


def _means(arrays: list[np.ndarray], column: int = 0) -> np.ndarray:
    """``(B, P)`` means of one column of every point's resampled ``(B, n, c)`` episodes."""
    return np.stack([a[..., column].mean(axis=1) for a in arrays], axis=1)


class _Data:
    """Paired episode arrays of one world."""

    def __init__(self, cells: Cells, scenario: str) -> None:
        self.cells = cells
        self.scenario = scenario

    def paired(self, setting: Setting, algorithms: Sequence[str], column: str) -> np.ndarray:
        worlds = {cell_of(self.scenario, setting, a)[0] for a in algorithms}
        assert len(worlds) == 1
        labels = [cell_of(self.scenario, setting, a)[1] for a in algorithms]
        return self.cells.paired(worlds.pop(), labels, column)

    def one(self, setting: Setting, algorithm: str) -> Any:
        return self.cells.get(*cell_of(self.scenario, setting, algorithm))


#: Success rate below which a method "fails" (the paper's 0 %, allowing for the sampling error
#: of a few hundred episodes).
FAIL_RATE = 0.05


def _best_everywhere(
    data: _Data,
    settings: Sequence[Setting],
    column: str,
    rng: np.random.Generator,
    method: str = "muc-osl",
) -> tuple[str, str]:
    """``method`` (MUC-OSL or its ablation) against every baseline at every setting:
    ``(ours, verdict)``."""
    higher = column == "success"
    baselines = [a for a in ALGORITHMS if a != "muc-osl"]
    best = lost = total = 0
    verdicts: list[str] = []
    # (margin in the claim's favour, difference, where): the least favourable comparison
    worst: tuple[float, float, str] = (math.inf, math.nan, "")
    for s in settings:
        x = data.paired(s, [method, *baselines], column)
        if len(x) == 0:
            verdicts.append("undecided")
            continue
        total += 1
        m = x.mean(axis=0)
        if (m[0] >= m[1:]).all() if higher else (m[0] <= m[1:]).all():
            best += 1
        point_lost = False
        for j, b in enumerate(baselines, start=1):
            d, lo, hi = bootstrap(
                lambda a, j=j: (a[0][..., 0] - a[0][..., j]).mean(axis=1), [x], rng
            )
            v = verdict(lo, hi, +1 if higher else -1)
            verdicts.append(v)
            point_lost |= v == "not held"
            margin = d if higher else -d
            if margin < worst[0]:
                worst = (margin, d, f"{LABELS[b]} at {_where(s)}")
        lost += point_lost
    what = "SR" if higher else "MST"
    diff = f"{100 * worst[1]:+.0f} pts" if higher else f"{worst[1]:+.0f} s"
    ours = (
        f"{what} best at {best} of {total} points, significantly worse than a baseline at "
        f"{lost}; least favourable: {worst[2]} ({LABELS[method]} {diff})"
        if total
        else "no episodes"
    )
    return ours, combine(verdicts)


def _where(s: Setting) -> str:
    parts = []
    if s.area != DEFAULT.area:
        parts.append("x".join(f"{v:g}" for v in s.area))
    if s.n_uavs != DEFAULT.n_uavs:
        parts.append(f"{s.n_uavs} UAVs")
    if s.radius != DEFAULT.radius:
        parts.append(f"r={s.radius:g}")
    if s.n_particles != DEFAULT.n_particles:
        parts.append(f"N={s.n_particles}")
    return ", ".join(parts) or "default"


def _trend(
    data: _Data,
    sweep: SweepDef,
    algorithm: str,
    column: str,
    rng: np.random.Generator,
    values: Sequence[Any] | None = None,
) -> tuple[float, float, float]:
    """Slope (per unit of the swept value) of ``column`` over ``values``, with its interval."""
    vals = list(sweep.values if values is None else values)
    groups = [data.paired(sweep.setting(v), [algorithm], column) for v in vals]
    counts = [len(g) for g in groups]
    return bootstrap(lambda a: slope(vals, _means(a), counts), groups, rng)


def _trend_claims(
    data: _Data, sweep: SweepDef, knee: float, what: str, rng: np.random.Generator
) -> list[Claim]:
    """ "SR rises / MST falls with ``what``" and "flattening beyond ``knee``" for all four."""
    out: list[Claim] = []
    if len(sweep.values) < 2:
        return out
    unit = {"uavs": "UAV", "particles": "10 particles"}[sweep.key]
    per = 10.0 if sweep.key == "particles" else 1.0
    low = [v for v in sweep.values if v <= knee]
    high = [v for v in sweep.values if v >= knee]
    for column, name, direction, scale in (
        ("success", "SR rises", +1, 100.0),
        ("time", "MST falls", -1, 1.0),
    ):
        texts, verdicts, flat_texts, flat_verdicts = [], [], [], []
        for a in ALGORITHMS:
            v, lo, hi = _trend(data, sweep, a, column, rng)
            texts.append(f"{LABELS[a]} {_ci_text(v * per, lo * per, hi * per, scale)}")
            verdicts.append(verdict(lo, hi, direction))
            if len(low) < 2 or len(high) < 2:
                continue
            groups_lo = [data.paired(sweep.setting(x), [a], column) for x in low]
            groups_hi = [data.paired(sweep.setting(x), [a], column) for x in high]
            c_lo, c_hi = [len(g) for g in groups_lo], [len(g) for g in groups_hi]

            def knee_fn(
                arr: list[np.ndarray], c_lo=c_lo, c_hi=c_hi, direction=direction
            ) -> np.ndarray:
                s_lo = slope(low, _means(arr[: len(low)]), c_lo)
                s_hi = slope(high, _means(arr[len(low) :]), c_hi)
                return direction * (s_lo - s_hi)

            d, d_lo, d_hi = bootstrap(knee_fn, [*groups_lo, *groups_hi], rng)
            s_lo = _trend(data, sweep, a, column, rng, low)
            s_hi = _trend(data, sweep, a, column, rng, high)
            flat_texts.append(
                f"{LABELS[a]} {s_lo[0] * per * scale:+.0f} then {s_hi[0] * per * scale:+.0f} "
                f"(diff {_ci_text(d * per, d_lo * per, d_hi * per, scale)})"
            )
            flat_verdicts.append(
                combine([verdict(s_lo[1], s_lo[2], direction), verdict(d_lo, d_hi, +1)])
            )
        u = "pts" if column == "success" else "s"
        out.append(
            Claim(
                "rate",
                f"{name} with more {what} (all four)",
                sweep.figure,
                f"slope, {u} per {unit}: " + "; ".join(texts),
                combine(verdicts),
            )
        )
        if not flat_texts:
            continue
        out.append(
            Claim(
                "rate",
                f"{name.split()[0]} levels off beyond {knee:g} {what} (all four)",
                sweep.figure,
                f"slope up to / from {knee:g}, {u} per {unit}: " + "; ".join(flat_texts),
                combine(flat_verdicts),
            )
        )
    return out


def _radius_claims(data: _Data, sweep: SweepDef, rng: np.random.Generator) -> list[Claim]:
    pair = ["col-pf", "adap-pp"]
    vals = list(sweep.values)
    out: list[Claim] = []
    texts, verdicts = [], []
    for column, direction, scale, u in (("success", +1, 100.0, "pts"), ("time", -1, 1.0, "s")):
        groups = [data.paired(sweep.setting(v), pair, column) for v in vals]
        counts = [len(g) for g in groups]

        def fn(a: list[np.ndarray], groups=groups, counts=counts) -> np.ndarray:
            return slope(vals, _means(a, 0), counts) - slope(vals, _means(a, 1), counts)

        v, lo, hi = bootstrap(fn, groups, rng)
        what = "SR" if column == "success" else "MST"
        texts.append(f"{what} {_ci_text(v * 10, lo * 10, hi * 10, scale)} {u}")
        verdicts.append(verdict(lo, hi, direction))
    if len(vals) >= 2:
        out.append(
            Claim(
                "rate",
                "Col-PF depends on the radius more than Adap-PP",
                sweep.figure,
                "slope per 10 m, Col-PF minus Adap-PP: " + "; ".join(texts),
                combine(verdicts),
            )
        )
    small = [v for v in vals if v <= 10.0]
    if not small:
        return out
    texts, verdicts = [], []
    for column, direction, scale, u in (("success", -1, 100.0, "pts"), ("time", +1, 1.0, "s")):
        groups = [data.paired(sweep.setting(v), pair, column) for v in small]

        def diff(a: list[np.ndarray]) -> np.ndarray:
            return np.mean([(x[..., 0] - x[..., 1]).mean(axis=1) for x in a], axis=0)

        v, lo, hi = bootstrap(diff, groups, rng)
        texts.append(f"{'SR' if column == 'success' else 'MST'} {_ci_text(v, lo, hi, scale)} {u}")
        verdicts.append(verdict(lo, hi, direction))
    out.append(
        Claim(
            "rate",
            "Col-PF is worse than Adap-PP at small radii (0-10 m)",
            sweep.figure,
            "Col-PF minus Adap-PP: " + "; ".join(texts),
            combine(verdicts),
        )
    )
    return out


def _area_claims(data: _Data, sweep: SweepDef, rng: np.random.Generator) -> list[Claim]:
    if len(sweep.values) < 2:
        return []
    small, large = sweep.setting(sweep.values[0]), sweep.setting(sweep.values[-1])
    algos = list(ALGORITHMS)
    ci = algos.index("col-inf")
    texts, verdicts = [], []
    for column, direction, scale, u in (("success", +1, 100.0, "pts"), ("time", -1, 1.0, "s")):
        groups = [data.paired(small, algos, column), data.paired(large, algos, column)]

        def fn(a: list[np.ndarray], direction=direction) -> np.ndarray:
            drop = direction * (a[0].mean(axis=1) - a[1].mean(axis=1))  # (B, 4)
            others = np.delete(drop, ci, axis=1).max(axis=1)
            return drop[:, ci] - others

        v, lo, hi = bootstrap(fn, groups, rng)
        what = "SR drop" if column == "success" else "MST rise"
        texts.append(f"{what} {_ci_text(v, lo, hi, scale)} {u}")
        verdicts.append(verdict(lo, hi, +1))
    area_text = "x".join(f"{v:g}" for v in large.area)
    claims = [
        Claim(
            "rate",
            "Col-Inf degrades most with the area",
            sweep.figure,
            "Col-Inf minus the largest other, smallest to largest area: " + "; ".join(texts),
            combine(verdicts),
        )
    ]
    if tuple(large.area) != (100.0, 200.0, 50.0):
        return claims
    out = claims
    g = data.one(large, "col-inf")
    k, n = int(g["success"].sum()), len(g)
    # "fails": held when the interval rules out more than FAIL_RATE, not held when it lies
    # above it (0 of 8 is [0, 32] %: undecided)
    lo, hi = stats.wilson_interval(k, n) if n else (math.nan, math.nan)
    out.append(
        Claim(
            "rate",
            f"Col-Inf fails at {area_text} m",
            f"{sweep.figure}: {100 * LARGEST_AREA_SUCCESS['col-inf']:.0f} %",
            f"Col-Inf SR {_pct(k, n)}",
            "undecided"
            if n == 0
            else ("held" if hi <= FAIL_RATE else "not held" if lo > FAIL_RATE else "undecided"),
        )
    )
    g = data.one(large, "muc-osl")
    k, n = int(g["success"].sum()), len(g)
    lo, hi = stats.wilson_interval(k, n) if n else (math.nan, math.nan)
    v = (
        "undecided"
        if n == 0
        else (
            "held"
            if k > 0
            else ("not held" if hi < LARGEST_AREA_SUCCESS["muc-osl"] else "undecided")
        )
    )
    out.append(
        Claim(
            "rate",
            f"MUC-OSL still succeeds at {area_text} m",
            f"{sweep.figure}: {100 * LARGEST_AREA_SUCCESS['muc-osl']:.0f} %",
            f"MUC-OSL SR {_pct(k, n)}",
            v,
        )
    )
    return out


def _energy_claims(
    data: _Data, rng: np.random.Generator, method: str = "muc-osl", world: str = "rate"
) -> list[Claim]:
    x = data.paired(DEFAULT, [method, "col-inf"], "energy")

    def rel(a: list[np.ndarray]) -> np.ndarray:
        return a[0][..., 0].mean(axis=1) / a[0][..., 1].mean(axis=1) - 1.0

    v, lo, hi = bootstrap(rel, [x], rng)
    out = [
        Claim(
            world,
            f"{LABELS[method]}: movement energy E_M below Col-Inf's",
            f"Table 2: {-100 * ENERGY_SAVING:+.2f} %",
            f"{_ci_text(v, lo, hi, 100.0, 1)} % over {len(x)} paired episodes",
            verdict(lo, hi, -1),
        )
    ]
    texts, verdicts = [], []
    for column, name in (("hover", "hover"), ("turn", "turn")):
        y = data.paired(DEFAULT, [method, "col-inf"], column)
        d, d_lo, d_hi = bootstrap(lambda a: (a[0][..., 0] - a[0][..., 1]).mean(axis=1), [y], rng)
        texts.append(f"{name} time {_ci_text(d, d_lo, d_hi)} s")
        verdicts.append(verdict(d_lo, d_hi, -1))
    out.append(
        Claim(
            world,
            "... with less hovering and turning",
            "Table 2: -45 s hover, -33 s turn",
            f"{LABELS[method]} minus Col-Inf, team: " + "; ".join(texts),
            combine(verdicts),
        )
    )
    return out


def _ablation_claims(data: _Data, world: str, rng: np.random.Generator) -> list[Claim]:
    """The paper's headline statements for MUC-OSL without eq. 16, at the default point
    (where the ablation runs); nothing when it has no episodes there."""
    if len(data.one(DEFAULT, NO_ENV_PU)) == 0:
        return []
    out = []
    for column, text in (("success", "highest SR"), ("time", "lowest MST")):
        ours, v = _best_everywhere(data, [DEFAULT], column, rng, NO_ENV_PU)
        out.append(
            Claim(world, f"{LABELS[NO_ENV_PU]}: the {text} (default point)", "Figs. 4-7", ours, v)
        )
    if world == "rate":
        out += _energy_claims(data, rng, NO_ENV_PU, world)
    return out


def when_text(at: float) -> str:
    """A time in seconds as the tables show it: whole minutes in minutes (``"8 min"``), else
    seconds (``"20 s"``)."""
    return f"{at / 60:g} min" if at % 60 == 0 else f"{at:g} s"


def _success_by(g: Any, limit: float) -> np.ndarray:
    return (g["success"].to_numpy(bool) & (g["time"].to_numpy(float) <= limit)).astype(float)


def _filament_claims(
    fil: _Data,
    rate: _Data,
    sweeps: Sequence[SweepDef],
    at: float,
    rng: np.random.Generator,
) -> list[Claim]:
    out = []
    paper = when_text(FILAMENT_AT)

    def judged(lo: float, hi: float, margin: float) -> str:
        v = verdict(lo, hi, +1, margin)
        # read before the paper's time (a shorter episode limit), the success rate is only a
        # lower bound of the paper's: it can confirm the statement but not refute it
        return "undecided" if v == "not held" and at < FILAMENT_AT else v

    g = fil.one(DEFAULT, "muc-osl")
    s = _success_by(g, at)
    k, n = int(s.sum()), len(s)
    lo, hi = stats.wilson_interval(k, n) if n else (math.nan, math.nan)
    out.append(
        Claim(
            "filament",
            f"MUC-OSL succeeds in about 90 % by {paper} (100x60x30 m)",
            f"Fig. 9(a): about {100 * FILAMENT_SUCCESS_8MIN:.0f} %",
            f"SR at {when_text(at)} {_pct(k, n)}",
            judged(lo, hi, BALLPARK * FILAMENT_SUCCESS_8MIN),
        )
    )
    uav_sweep = next((sw for sw in sweeps if sw.key == "uavs"), None)
    big = [v for v in uav_sweep.values if v > 3] if uav_sweep is not None else []
    if uav_sweep is not None and big:
        s = np.concatenate([_success_by(fil.one(uav_sweep.setting(v), "muc-osl"), at) for v in big])
        k, n = int(s.sum()), len(s)
        lo, hi = stats.wilson_interval(k, n) if n else (math.nan, math.nan)
        out.append(
            Claim(
                "filament",
                f"MUC-OSL above 80 % by {paper} with more than 3 UAVs",
                f"Fig. 9(b): > {100 * FILAMENT_SUCCESS_8MIN_MANY_UAVS:.0f} %",
                f"SR at {when_text(at)}, {', '.join(str(v) for v in big)} UAVs: {_pct(k, n)}",
                judged(lo, hi, FILAMENT_SUCCESS_8MIN_MANY_UAVS),
            )
        )
    settings = _distinct(sweeps)
    ours, v = _best_everywhere(fil, settings, "success", rng)
    out.append(Claim("filament", "MUC-OSL has the highest SR at every setting", "Fig. 9", ours, v))
    groups = []
    for st in settings:
        groups.append(fil.paired(st, ["muc-osl"], "success"))
        groups.append(rate.paired(st, ["muc-osl"], "success"))

    def diff(a: list[np.ndarray]) -> np.ndarray:
        return np.mean(
            [
                a[i][..., 0].mean(axis=1) - a[i + 1][..., 0].mean(axis=1)
                for i in range(0, len(a), 2)
            ],
            axis=0,
        )

    d, d_lo, d_hi = bootstrap(diff, groups, rng) if groups else (math.nan,) * 3
    out.append(
        Claim(
            "filament",
            "MUC-OSL does the same or better than in the rate world",
            "Sect. VI.3",
            f"SR filament minus rate over the {len(settings)} settings: "
            f"{_ci_text(d, d_lo, d_hi, 100.0)} pts",
            verdict(d_lo, d_hi, +1),
        )
    )
    return out


def _distinct(sweeps: Sequence[SweepDef]) -> list[Setting]:
    out: list[Setting] = []
    for sw in sweeps:
        for s in sw.settings():
            if s not in out:
                out.append(s)
    return out


def evaluate_claims(
    cells: Cells,
    rate_scenario: str,
    rate_sweeps: Sequence[SweepDef],
    filament_scenario: str | None = None,
    filament_sweeps: Sequence[SweepDef] = (),
    at: float = FILAMENT_AT,
    seed: int = 0,
) -> list[Claim]:
    """Every statement of the module table that the stored episodes can address.

    Parameters
    ----------
    cells : Cells
    rate_scenario, filament_scenario : str
        The two worlds' scenario names.
    rate_sweeps, filament_sweeps : sequence of SweepDef
    at : float, seconds
        The time the filament world's success rates are read at: the paper's 8 minutes, or the
        episode limit when that is shorter. The statements keep the paper's 8 minutes; read
        earlier, a success rate below the paper's is ``undecided``, not ``not held``.
    seed : int
        Seed of the bootstrap.
    """
    rng = np.random.default_rng([seed, 15])
    rate = _Data(cells, rate_scenario)
    by = {sw.key: sw for sw in rate_sweeps}
    out: list[Claim] = []
    settings = _distinct(rate_sweeps)
    for column, text in (("success", "highest SR"), ("time", "lowest MST")):
        ours, v = _best_everywhere(rate, settings, column, rng)
        out.append(Claim("rate", f"MUC-OSL has the {text} at every point", "Figs. 4-7", ours, v))
    if "uavs" in by:
        out += _trend_claims(rate, by["uavs"], 5, "UAVs", rng)
    if "particles" in by:
        out += _trend_claims(rate, by["particles"], 160, "particles", rng)
    if "radius" in by:
        out += _radius_claims(rate, by["radius"], rng)
    if "area" in by:
        out += _area_claims(rate, by["area"], rng)
    out += _energy_claims(rate, rng)
    out += _ablation_claims(rate, "rate", rng)
    if filament_scenario is not None and filament_sweeps:
        fil = _Data(cells, filament_scenario)
        out += _filament_claims(fil, rate, filament_sweeps, at, rng)
        out += _ablation_claims(fil, "filament", rng)
    return out
