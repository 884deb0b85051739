"""Multi-UAV collaborative source localization paper (MUC-OSL) in 3-D.

``shared/papers/muc-osl-multi-uav.txt``. Scenario ``muc-osl-3d`` (three UAVs with the paper's
timing and energy model in a Vergassola encounter-rate world).
"""
