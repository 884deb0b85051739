"""Recorded data in and out (extra ``odorloc[ros]`` for bags): robot logs from ROS bags
(:mod:`.bag`), GADEN simulations (:mod:`.gaden`), and estimators replayed offline over a log
(:mod:`.offline`).
"""
