"""Source-term estimation: the posterior of position, release rate, wind, dispersion and the
number of sources, by a resample-move particle filter (registry ``estimator/ste-pf``)."""

from __future__ import annotations

from odorloc.inference.source_terms.belief import CredibleRegion, SourceTermBelief
from odorloc.inference.source_terms.estimator import SourceTermEstimator, SourceTermParams
from odorloc.inference.source_terms.multi import (
    ExtractedSources,
    count_distribution,
    extract_sources,
)
from odorloc.inference.source_terms.priors import (
    LogUniformPrior,
    NormalPrior,
    SourceTermPrior,
    UniformPrior,
    VonMisesPrior,
)

__all__ = [
    "CredibleRegion",
    "ExtractedSources",
    "LogUniformPrior",
    "NormalPrior",
    "SourceTermBelief",
    "SourceTermEstimator",
    "SourceTermParams",
    "SourceTermPrior",
    "UniformPrior",
    "VonMisesPrior",
    "count_distribution",
    "extract_sources",
]
