"""Recordings kept in a result store, looked up by the columns of their rows."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from odorloc.engine.recorder import Recording

__all__ = ["kept_recordings"]


def kept_recordings(
    df: Any, store: Any, where: Mapping[str, Any], by: str, episode: int = 0
) -> dict[Any, Recording]:
    """The stored recordings of ``episode`` of the rows matching ``where`` (column -> value),
    keyed by their value of column ``by``; rows without stored arrays are left out."""
    sel = df[df["episode"] == episode]
    for col, value in where.items():
        sel = sel[sel[col].astype(type(value)) == value] if col in sel else sel.iloc[:0]
    out: dict[Any, Recording] = {}
    for _, row in sel.iterrows():
        arrays = store.arrays(str(row["cell_id"]), episode)
        if arrays is not None:
            out.setdefault(row[by], Recording.from_arrays(arrays))
    return out
