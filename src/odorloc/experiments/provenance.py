"""What a results store records about the runs that filled it, so that a report says what was
run, with which version, where and for how long."""

from __future__ import annotations

import os
import platform
import sys
import time
from typing import Any

__all__ = ["machine", "run_record"]


def machine() -> str:
    """``"Linux 6.1 x86_64, 2 CPUs, Python 3.11.2"``: the operating system, the architecture,
    the processors and the Python version (no host name: reports get published)."""
    return (
        f"{platform.system()} {platform.release()} {platform.machine()}, "
        f"{os.cpu_count() or '?'} CPUs, Python {sys.version.split()[0]}"
    )


def run_record(
    started: float, wall_time: float, added: int, backend: str, workers: int
) -> dict[str, Any]:
    """One run of a sweep: when it started (UTC), its wall time (s), the episodes it added,
    where it ran, and the odorloc version and machine."""
    from odorloc import __version__

    return {
        "started": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime(started)),
        "wall_time": round(float(wall_time), 3),
        "added": int(added),
        "backend": backend,
        "workers": int(workers),
        "odorloc_version": __version__,
        "machine": machine(),
    }
