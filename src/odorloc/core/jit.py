"""Compiled kernels: numba (a dependency) with a cache that hits across processes.

A kernel is compiled once per machine and loaded from the cache by every later process (a sweep
worker, a second ``odorloc run``). The cache lives in the user's cache folder, never in the
package's source tree: ``$ODORLOC_CACHE_DIR/numba`` if that variable is set, else
``$XDG_CACHE_HOME/odorloc/numba`` (``~/.cache/odorloc/numba``), else a per-user folder under the
system's temporary folder when neither can be written. A ``NUMBA_CACHE_DIR`` set by the user is
respected.

Kernels must be module-level functions that reference other kernels only as module globals
(never as closure variables): numba keys a closure's cache entry by its pickled free variables,
which differ from process to process, so a closure kernel would be compiled anew in every
process and add a cache file each time.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

__all__ = [
    "HAVE_NUMBA",
    "cache_dir",
    "jit",
    "kernels",
    "prange",
    "set_threads",
    "start",
    "threads",
    "warm",
]

try:
    import numba as _numba

    HAVE_NUMBA = True
    #: A loop whose iterations a kernel compiled with ``parallel=True`` shares among numba's
    #: threads (``range`` in any other kernel, and without numba).
    prange = _numba.prange
except ImportError:  # pragma: no cover - exercised only without the extra
    _numba = None
    HAVE_NUMBA = False
    prange = range


def _writable(p: Path) -> bool:
    try:
        p.mkdir(parents=True, exist_ok=True)
    except OSError:
        return False
    return os.access(p, os.W_OK | os.X_OK)


def cache_dir() -> Path:
    """The folder compiled kernels are cached in (created if needed; see the module docstring)."""
    user = os.environ.get("NUMBA_CACHE_DIR")
    if user:
        return Path(user)
    own = os.environ.get("ODORLOC_CACHE_DIR")
    if own:
        candidates = [Path(own) / "numba"]
    else:
        xdg = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
        candidates = [Path(xdg) / "odorloc" / "numba"]
    uid = os.getuid() if hasattr(os, "getuid") else "user"
    candidates.append(Path(tempfile.gettempdir()) / f"odorloc-{uid}" / "numba")
    for c in candidates:
        if _writable(c):
            return c
    return candidates[-1]


_CONFIGURED: list[str] = []


def _configure() -> None:
    """Point numba's cache at :func:`cache_dir` (once, before the first kernel is declared)."""
    if _CONFIGURED or _numba is None:
        return
    path = str(cache_dir())
    # numba reads the folder when a kernel is declared; the environment variable also reaches
    # worker processes started from this one
    os.environ.setdefault("NUMBA_CACHE_DIR", path)
    _numba.config.CACHE_DIR = os.environ["NUMBA_CACHE_DIR"]
    _CONFIGURED.append(path)


_WARMERS: list[Callable[[], Any]] = []


def jit(
    fn: Callable[..., Any], warmup: Callable[[Any], Any] | None = None, **options: Any
) -> Callable[..., Any]:
    """``fn`` compiled with ``numba.njit(cache=True, **options)``, or ``fn`` itself without
    numba (callers that need the speed check :data:`HAVE_NUMBA`).

    ``warmup(kernel)`` calls the kernel once on tiny arguments of the types it is used with;
    :func:`warm` runs every such call.
    """
    if _numba is None:
        return fn
    _configure()
    kernel = _numba.njit(cache=True, **options)(fn)
    _KERNELS[f"{fn.__module__}.{fn.__qualname__}"] = kernel
    if warmup is not None:
        _WARMERS.append(lambda: warmup(kernel))
    return kernel


_KERNELS: dict[str, Any] = {}


def kernels() -> dict[str, Any]:
    """Every compiled kernel declared in this process, by ``module.function`` (``"runtime"``
    for the one :func:`start` loads): numba dispatchers, whose ``stats`` count cache hits and
    misses. Empty without numba."""
    return dict(_KERNELS)


def warm() -> float:
    """Load every declared kernel now (from the cache; compiling only if it is cold).

    The first call of any numba kernel in a process also initialises numba's own typing and
    target registries (a few tenths of a second, independent of the cache); a process about to
    run episodes (a sweep worker) calls this at start, so its first episode costs what the
    others do.

    Returns
    -------
    float
        Seconds spent.
    """
    import time

    t0 = time.perf_counter()
    from odorloc.core import registry

    registry.load_all()  # imports the component modules, which declare their kernels
    for w in list(_WARMERS):
        w()
    return time.perf_counter() - t0


def _identity(x: float) -> float:
    return x


_RUNTIME: list[Callable[[float], float]] = []


def start() -> float:
    """Bring numba's runtime up now, without loading any particular kernel.

    The first call of any numba kernel in a process sets up numba's typing and target
    registries and binds SciPy's BLAS (importing :mod:`scipy.linalg`): a few tenths of a second
    that do not depend on the cache and are not compilation. A command about to run an episode
    in its own process (``odorloc run``) pays it here, at start-up, so that the episode's
    reported time is the episode's own; the kernels themselves then load from the cache on
    their first call (milliseconds each). Nothing without numba.

    Returns
    -------
    float
        Seconds spent.
    """
    import time

    t0 = time.perf_counter()
    if _numba is not None and not _RUNTIME:
        _configure()
        kernel = _numba.njit(cache=True)(_identity)
        kernel(0.0)
        _RUNTIME.append(kernel)
        _KERNELS["runtime"] = kernel
    return time.perf_counter() - t0


def threads() -> int:
    """How many threads a ``parallel=True`` kernel may use in this process (1 without
    numba)."""
    return 1 if _numba is None else int(_numba.config.NUMBA_NUM_THREADS)


def set_threads(n: int) -> None:
    """Let the ``parallel=True`` kernels called from this thread use ``n`` threads (at most
    :func:`threads`; nothing without numba)."""
    if _numba is not None:
        _numba.set_num_threads(n)
