"""The composed simulated world: an arena, a wind field and a plume on one clock."""

from odorloc.world.world import World

__all__ = ["World"]
