"""Reactive behaviours: one implementation of each motion rule, used by every searcher.

- :mod:`.escape`: the first free direction among candidates, free moves and random escapes;
- :mod:`.zigzag`: Z-shaped legs at an angle to the wind (indoor PF paper, Fig. 1);
- :mod:`.surge_cast`: moth-inspired upwind surge, then widening crosswind casts (tilted in 3-D);
- :mod:`.spiral`: square spirals restarted on a better proximity index;
- :mod:`.taxis`: chemotaxis, anemotaxis and fluxotaxis rules over sample sets;
- :mod:`.stop_and_go`: one move of at most a period's reach, then standing still to read;
- :mod:`.monitor`: passive monitoring and the strongest-reading memory;
- :mod:`.formation`: virtual-structure formation forces around a virtual leader and the flux
  declaration of a formation (virtual-physics paper);
- :mod:`.groups`: forces between groups: repulsion, forbidden areas, rotary bypass.
"""
