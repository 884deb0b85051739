"""Source-term estimation: searches over the posterior of position, release rate and wind.

Scenarios ``ste-gaussian`` (the Park & Oh RA-L 2022 benchmark setting, after its public
``gym_ste`` environment), ``ste-vergassola-3d`` (Poisson encounters in 3-D),
``ste-calibration`` (a fixed route, the truth drawn from the prior) and
``ste-three-sources-farrell`` (a third source in the D-S paper's flow); ``odorloc reproduce
source-terms`` runs infotaxis, entrotaxis and a lawn-mower on the first two, the calibration
study, and the multi-source posterior beside the D-S map (:mod:`.reproduction`).
"""
