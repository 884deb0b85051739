"""Virtual-physics paper: groups of robots in formations locating several sources.

``shared/papers/virtual-physics-multi-group.txt``. Scenario ``virtual-physics-two-groups`` (20 m
x 20 m, two sources, meandering 5 m/s inflow, two groups of six robots, start sets P1-P6, a
``frequency`` knob); the method is the ``virtual-physics`` formation searcher run per group
(``per-group`` team); ``odorloc reproduce virtual-physics`` runs Sec. 3 (three rules x three
frequencies x six starts, ablations) with the figures of Figs. 5-10. The release rate is
calibrated in :mod:`.calibration`.
"""
