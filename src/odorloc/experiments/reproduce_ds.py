"""Reproduction of the D-S multi-source mapping paper (registered by :mod:`.reproduce`)."""
