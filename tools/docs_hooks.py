"""MkDocs hooks: the parts of the documentation generated when the site is built.

- ``<!-- odorloc:components -->`` becomes the Components reference: every registered component
  of every family, its description and a table of its parameters (type, default, unit, doc),
  read from the registry (:mod:`odorloc.core.describe`), so it can never fall behind the code.
- ``<!-- odorloc:output odorloc ARGS -->`` becomes a ``console`` block holding the command and
  what it prints at 80 columns (e.g. ``odorloc components pf-entropy``).

Named in ``mkdocs.yml`` under ``hooks:``.
"""

from __future__ import annotations

import re
import shlex
from typing import Any

#: What each family is, for the Components reference (families added later get a plain heading).
FAMILIES = {
    "wind": "Wind fields: what moves the air (and the odor) at every point and time.",
    "plume": "Plumes: the odor the sensors read, behind one interface (concentration, "
    "encounter rate, frames).",
    "source_draw": "Ways to draw the source position anew for every episode.",
    "gas_sensor": "Gas sensors: turn the plume at the agent into a reading and a detection.",
    "anemometer": "Anemometers: the wind an agent measures.",
    "platform": "Platforms: how an agent moves, how long it takes and what it costs.",
    "model": "Measurement models: the likelihood of a reading given a source hypothesis, used "
    "by estimators and planners (a searcher's model may differ from the world's plume).",
    "resampler": "Particle-filter resampling schemes, ``scheme(weights, M, rng)``.",
    "estimator": "Single-agent estimators: a belief about the source, updated from every "
    "observation (``reset``, ``update``, ``belief``, ``estimate``, ``converged``).",
    "reading": "Parts of a particle filter: how one observation becomes a likelihood (a "
    "detection under the recorded wind window, or an outcome class).",
    "particle_init": "Parts of a particle filter: where its particles start.",
    "resampling_policy": "Parts of a particle filter: when it resamples.",
    "stopping_rule": "Parts of a particle filter: when its estimate is good enough to declare.",
    "planner": "Planners: the next target from a belief and the agent's pose "
    "(``plan(belief, pose, rng)`` returns a ``Plan``).",
    "candidates": "Parts of a planner: the targets it scores.",
    "reward": "Parts of a planner: the score of a candidate (lower is better).",
    "selection": "Parts of a planner: the candidate chosen from the scores, ties included.",
    "team_estimator": "Team estimators: one per UAV, exchanging Gaussian fits.",
    "step_planner": "Step planners of the UAV teams: a direction and a step length per decision.",
    "searcher": "Searchers: strategies that turn observations into commands and declarations.",
    "reproduction": "Reproductions: a paper's headline comparison (``odorloc reproduce NAME``).",
}

_OUTPUT = re.compile(r"^<!-- odorloc:output (odorloc .+?) -->$", re.M)


def components_markdown() -> str:
    """The whole Components reference (every family, every member)."""
    from odorloc.core import describe, registry
    from odorloc.experiments.reproduction import discover

    discover()  # the papers' reproductions are components too
    out = []
    for family in registry.families():
        out.append(f"## {family}\n")
        text = FAMILIES.get(family, "")
        if text:
            out.append(describe.markdown(text) + "\n")
        names = registry.names(family)
        out.append("Members: " + ", ".join(f"[`{n}`](#{family}-{n})" for n in names) + ".\n")
        for name in names:
            doc = describe.describe(family, name)
            section = describe.render_markdown(doc, level=3)
            # headings carry the family, so that a name of two families has two anchors
            section = section.replace(
                f"### `{name}`", f"### `{name}` ({family}) {{ #{family}-{name} }}", 1
            )
            out.append(section)
    return "\n".join(out)


def command_output(line: str) -> str:
    """A ``console`` block: ``$ LINE`` and what the command prints at 80 columns."""
    from typer.testing import CliRunner

    from odorloc.cli import app

    args = shlex.split(line)[1:]
    result = CliRunner().invoke(app, args, env={"COLUMNS": "80", "NO_COLOR": "1"})
    if result.exit_code != 0:
        raise RuntimeError(f"docs: `{line}` exited {result.exit_code}: {result.output}")
    text = result.stdout.rstrip("\n")
    return f"```console\n$ {line}\n{text}\n```"


def on_page_markdown(markdown: str, page: Any, config: Any, files: Any) -> str:
    """Fill in the generated parts of a page (see the module docstring)."""
    if "<!-- odorloc:components -->" in markdown:
        markdown = markdown.replace("<!-- odorloc:components -->", components_markdown())
    return _OUTPUT.sub(lambda m: command_output(m.group(1)), markdown)
