"""Indoor PF + entropy paper: plume-model particle filter with information-entropy moves.

``shared/papers/indoor-pf-entropy.txt``. Scenarios ``indoor-ventilated`` (the paper's room) and
``indoor-obstacles``; the method is the ``pf-entropy`` searcher, the baseline
``gradient-bionic``; ``odorloc reproduce indoor-pf-entropy`` runs Table 1 and Fig. 8.
"""
