"""The virtual-physics paper's numbers (``shared/papers/virtual-physics-multi-group.txt``).

The paper gives its results as bar charts (Figs. 6, 8, 10) and quotes a few values in the text;
only those quoted values are here. Times are seconds to locate both sources.
"""

from __future__ import annotations

from odorloc.experiments.reproduction import Citation

#: Start sets: virtual-robot positions of groups A and B (Sec. 3).
START_SETS = {
    "P1": ((18.0, 4.0), (18.0, 14.0)),
    "P2": ((18.0, 10.0), (18.0, 14.0)),
    "P3": ((18.0, 4.0), (18.0, 10.0)),
    "P4": ((18.0, 14.0), (18.0, 16.0)),
    "P5": ((18.0, 8.0), (18.0, 10.0)),
    "P6": ((18.0, 4.0), (18.0, 6.0)),
}

#: Success rate per rule (Secs. 3.1-3.3): chemotaxis 100 % everywhere; anemotaxis 0 % from P4
#: and 100 % elsewhere; fluxotaxis "very similar to anemotaxis" (no rate is quoted).
SUCCESS = {
    "chemotaxis": {s: 1.0 for s in START_SETS},
    "anemotaxis": {s: (0.0 if s == "P4" else 1.0) for s in START_SETS},
}

#: Mean search time of chemotaxis by frequency factor (Sec. 3.1; twice frequency not quoted).
CHEMOTAXIS_TIME = {1: 780.0, 3: 1180.0}

#: Chemotaxis at treble frequency, mean time per start (Sec. 3.1).
CHEMOTAXIS_TREBLE_BY_START = dict(P1=1040.0, P2=870.0, P3=1160.0, P4=920.0, P5=970.0, P6=1090.0)

#: Anemotaxis mean time per start (Sec. 3.2; P4 fails; the frequency is not stated).
ANEMOTAXIS_BY_START = {"P1": 350.0, "P2": 390.0, "P3": 390.0, "P5": 460.0, "P6": 460.0}

#: Anemotaxis and fluxotaxis: "less than 400 s at three different frequencies" (Sec. 3.2).
FAST_RULES_BOUND = 400.0

SOURCE = {
    "chemotaxis": "Sec. 3.1, Figs. 5-6",
    "anemotaxis": "Sec. 3.2, Figs. 7-8",
    "fluxotaxis": "Sec. 3.3, Figs. 9-10 (similar to anemotaxis)",
}


def paper_success(label: str) -> str:
    """The paper's success rate of a rule over the six starts, % (as text; fluxotaxis is only
    "similar to anemotaxis")."""
    s = SUCCESS.get(label)
    if s is None:
        return "~anem." if label == "fluxotaxis" else "-"
    return f"{100 * sum(s.values()) / len(s):.0f}"


CITATION = Citation(
    authors="Ma, X.; Zhang, Y.; Miao, Y.",
    title="A Virtual Physics-based Approach to Multiple Odor Sources Localization",
    venue="TELKOMNIKA Indonesian Journal of Electrical Engineering 12(7), 5331-5341",
    year=2014,
    doi="10.11591/telkomnika.v12i7.5199",
)
