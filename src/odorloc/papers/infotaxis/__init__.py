"""Infotaxis and its successors on OTTO's lattice problem, and the single-agent library compared
on continuous worlds.

Papers: Vergassola, Villermaux & Shraiman (Nature 2007, infotaxis); Loisy & Eloy (Proc. R. Soc.
A 2022, space-aware infotaxis and the reference implementation OTTO); Hutchinson, Oh & Chen (2018,
entrotaxis). Scenarios ``lattice-isotropic-2d`` (lambda/dx = 1, R dt = 1),
``lattice-isotropic-2d-l2`` (lambda/dx = 2, R dt = 2) and ``lattice-isotropic-3d``
(:mod:`.lattice` builds them for any parameters); OTTO's own numbers in :mod:`.reference`;
``odorloc reproduce single-agent`` compares every single-agent strategy on three continuous
worlds (:mod:`.reproduction`).
"""
