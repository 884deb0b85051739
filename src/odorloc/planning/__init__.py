"""Planners: candidates x rewards x selection, grid paths and coverage patterns.

- :mod:`.candidates`: move sets (robot/wind/world frame moves, lattice moves, directions x
  step lengths) and their reachability;
- :mod:`.rewards`: expected posterior entropy (infotaxis), predictive entropy (entrotaxis),
  space-aware infotaxis, greedy and mean distance, with the "found" outcome;
- :mod:`.infotaxis`: the infotaxis-family planners on grid beliefs (table correlations) and
  on particle beliefs (pluggable candidates and outcome model);
- :mod:`.selection`: choosing one candidate with explicit tie rules;
- :mod:`.entropy`: the indoor PF paper's expected-entropy moves (a composition of the above);
- :mod:`.uncertainty_route`: the D-S paper's uncertainty-driven route;
- :mod:`.astar`, :mod:`.coverage`: A* on the occupancy grid, rectangular-wave coverage.
"""
