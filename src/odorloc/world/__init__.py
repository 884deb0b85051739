"""Arenas, odor sources and the composed simulated world."""

from odorloc.world.arena import Arena, as_points
from odorloc.world.sources import Modulation, Source
from odorloc.world.world import World

__all__ = ["Arena", "Modulation", "Source", "World", "as_points"]
