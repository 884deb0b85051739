"""Dempster-Shafer evidence grids of several sources, and the map the mapping searchers build."""
