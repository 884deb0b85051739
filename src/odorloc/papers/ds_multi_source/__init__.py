"""D-S multi-source mapping paper: evidence grid of several sources with an uncertainty route.

``shared/papers/ds-multi-source-mapping.txt``. Scenario ``two-sources-farrell``; methods
``ds-mapping`` (dynamic route) and ``ds-rectangular-wave`` (the baseline);
``odorloc reproduce ds-multi-source`` replays one recorded flow per episode to both.
"""
