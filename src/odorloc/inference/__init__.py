"""Estimators: particle filters, grid posteriors, evidence grids and odor-path maps.

- :mod:`.weights`: log-space normalisation, ESS, Gaussian fits, KL divergence;
- :mod:`.belief`: belief containers (particles, grids);
- :mod:`.particles`: the particle filter as a composition (constraints, resampling, stopping);
- :mod:`.grid_filter`: the grid Bayes filter over source cells (and release rates), log space;
- :mod:`.odor_path`: odor-path maps (odor-path paper);
- :mod:`.evidence`: Dempster-Shafer grids and the D-S map (D-S paper).
"""
