"""Gas distribution mapping: Kernel DM+V, DM+V/W, TD Kernel DM+V and the GMRF map compared.

``odorloc reproduce gas-maps`` explores ``indoor-ventilated`` and ``two-sources-farrell`` along
three paths (lawn-mower, random walk, the D-S route), replays each flow to the three, maps the
readings of every path with every member of the ``gas_map`` family and scores each map against
the plume's time-averaged concentration (:mod:`odorloc.experiments.gas_maps`).
"""
