"""Multi-UAV collaborative source localization paper (MUC-OSL) in 3-D.

``shared/papers/muc-osl-multi-uav.txt``. Scenario ``muc-osl-3d`` (three UAVs with the paper's
timing and energy model in a Vergassola encounter-rate world, wind towards -y); the method and
its baselines are the searchers ``muc-osl``, ``col-inf``, ``col-pf`` and ``adap-pp``, with
``muc-osl-printed`` and ``col-pf-printed`` for PUGL's moves as printed
(:mod:`odorloc.searchers.uav_team`); ``odorloc reproduce muc-osl`` compares them
(:mod:`.reproduction`); :mod:`.reference` holds the paper's numbers.
"""
