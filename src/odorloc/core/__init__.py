"""The neutral core: interface types, parameters, errors, the registry, seeds and time steps.

Everything else in odorloc imports from here; this package imports nothing of odorloc but the
arena type used in annotations.
"""

from __future__ import annotations

from odorloc.core.errors import ConfigError, OdorlocError
from odorloc.core.params import Finite, NonNegative, Params, Positive, Vector
from odorloc.core.types import (
    Action,
    ArrayPayload,
    Command,
    Declaration,
    Event,
    Group,
    Message,
    Observation,
    Payload,
    Region,
    SearchContext,
    SensorInfo,
)

__all__ = [
    "Action",
    "ArrayPayload",
    "Command",
    "ConfigError",
    "Declaration",
    "Event",
    "Finite",
    "Group",
    "Message",
    "NonNegative",
    "Observation",
    "OdorlocError",
    "Params",
    "Payload",
    "Positive",
    "Region",
    "SearchContext",
    "SensorInfo",
    "Vector",
]
