"""Odor-path paper: air-mass path maps by the dynamic-window method.

``shared/papers/odor-path-dynamic-window.txt``. The estimator is
:mod:`odorloc.inference.odor_path`; :mod:`.figures` draws the paper's Figs. 4-5 (calm and gusty
path maps with their sub-window ellipses) and ``benchmarks/odor_path_speed.py`` measures its cost
against the full-grid evaluation.
"""
