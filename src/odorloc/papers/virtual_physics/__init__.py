"""Virtual-physics paper (``shared/papers/virtual-physics-multi-group.txt``): groups of robots in
formations locating several sources. Scenario ``virtual-physics-two-groups``; the method is the
``virtual-physics`` formation searcher run per group; ``odorloc reproduce virtual-physics`` runs
Sec. 3 (:mod:`.reproduction`); the world is calibrated and measured in :mod:`.analysis`.
"""
