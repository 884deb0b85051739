"""Estimators: particle filters, grid posteriors, evidence grids and odor-path maps."""
