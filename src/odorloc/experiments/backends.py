"""Execution backends: run episode tasks and stream ``(task, row)`` pairs back as they finish.

Both backends send work in small chunks (a few episodes per work item) to keep the per-episode
overhead low, keep only a bounded number of chunks in flight (memory does not grow with the sweep)
and yield results in completion order; the caller (the parent process) writes them to the store.
Results do not depend on the backend or the number of workers because each task carries its own
seeds. An episode that kills its worker process (segfault, ``os._exit``, out of memory) is run
again alone and, if its worker dies again, recorded as a ``WorkerDied`` error row; the sweep goes
on with the other episodes.

- :class:`LocalBackend` -- a :class:`concurrent.futures.ProcessPoolExecutor` on this machine, no
  set-up (``workers=1`` runs in the calling process).
- :class:`DaskBackend` -- a Dask ``distributed`` cluster: a ``LocalCluster`` of ``workers``
  single-threaded processes, or an existing cluster given by its scheduler address. Needs the
  extra ``odorloc[dask]``; the episode function's module must be importable on the workers.
"""

from __future__ import annotations

import collections
import contextlib
import itertools
import math
import multiprocessing
import os
import select
import signal
import threading
import time
import traceback
from collections.abc import Callable, Iterable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from typing import Any

from odorloc.core.errors import ConfigError

TaskRow = tuple[Any, dict]

MAX_CHUNK = 8
"""Upper bound on episodes per work item (small, so results reach the store promptly)."""


def execute_task(episode_fn: Callable[[Any], dict], task: Any, keep_arrays: bool = False) -> dict:
    """Run one episode, turning an exception into an ``"error"`` row.

    ``wall_time`` (s) is measured here unless the episode function reports it; ``arrays`` is
    dropped unless ``keep_arrays`` (so it is never shipped back needlessly).
    """
    t0 = time.perf_counter()
    try:
        row = dict(episode_fn(task))
    except Exception as exc:
        tb = traceback.format_exc().strip().splitlines()
        # first line states the error; the tail of the traceback says where
        row = {
            "status": "error",
            "error": f"{type(exc).__name__}: {exc}\n" + "\n".join(tb[-12:]),
            "termination": "error",
            "success": False,
        }
    row.setdefault("status", "ok")
    row.setdefault("error", "")
    if row.get("wall_time") is None:
        row["wall_time"] = time.perf_counter() - t0
    if not keep_arrays:
        row.pop("arrays", None)
    return row


def run_chunk(
    episode_fn: Callable[[Any], Any],
    tasks: Sequence[Any],
    keep_arrays: bool = False,
    grouped: bool = False,
) -> list[dict]:
    """Run a chunk of tasks in order; one row per task (the unit of work sent to a worker).

    With ``grouped`` the function is a *group function* ``fn(tasks) -> rows`` called once for
    the whole chunk (e.g. one recorded flow replayed to every task); a failure then turns every
    task of the chunk into an error row.
    """
    if not grouped:
        return [execute_task(episode_fn, t, keep_arrays) for t in tasks]
    t0 = time.perf_counter()
    try:
        rows = [dict(r) for r in episode_fn(list(tasks))]
        if len(rows) != len(tasks):
            raise RuntimeError(f"group function returned {len(rows)} rows for {len(tasks)} tasks")
    except Exception as exc:
        tb = traceback.format_exc().strip().splitlines()
        err = f"{type(exc).__name__}: {exc}\n" + "\n".join(tb[-12:])
        rows = [
            {"status": "error", "error": err, "termination": "error", "success": False}
            for _ in tasks
        ]
    wall = (time.perf_counter() - t0) / max(len(tasks), 1)
    for row in rows:
        row.setdefault("status", "ok")
        row.setdefault("error", "")
        if row.get("wall_time") is None:
            row["wall_time"] = wall
        if not keep_arrays:
            row.pop("arrays", None)
    return rows


def died_rows(n: int) -> list[dict]:
    """Error rows for ``n`` tasks whose worker process died while running them alone."""
    return [
        {
            "status": "error",
            "error": "WorkerDied: the worker process running this episode died",
            "termination": "error",
            "success": False,
        }
        for _ in range(n)
    ]


def default_chunk_size(n_tasks: int, workers: int) -> int:
    """About four chunks per worker, at most :data:`MAX_CHUNK` episodes each."""
    return max(1, min(MAX_CHUNK, math.ceil(n_tasks / (4 * max(1, workers)))))


def _chunks(tasks: Iterable[Any], size: int) -> Iterator[list[Any]]:
    it = iter(tasks)
    while chunk := list(itertools.islice(it, size)):
        yield chunk


def _count(tasks: Iterable[Any], total: int | None) -> int:
    if total is not None:
        return total
    return len(tasks) if isinstance(tasks, Sequence) else MAX_CHUNK * 64


def _process_gone(pid: int) -> bool:
    """Whether process ``pid`` has ended (a zombie counts as ended)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    except PermissionError:
        return False
    try:
        with open(f"/proc/{pid}/stat", "rb") as fh:
            return fh.read().rsplit(b")", 1)[1].split()[0] in (b"Z", b"X")
    except (OSError, IndexError):
        return False


def watch_parent(pid: int, period: float = 0.5) -> None:
    """Worker initializer: end this process as soon as process ``pid`` (the sweep) is gone.

    A worker blocked waiting for work, or busy in an episode, would otherwise outlive a parent
    killed with SIGKILL (nothing tells it), and keep the pool's helper processes alive too. A
    daemon thread waits on a Linux pidfd of the parent (woken the moment it exits) or, where
    that is unavailable, polls every ``period`` seconds.
    """

    def watch() -> None:
        fd = None
        pidfd_open = getattr(os, "pidfd_open", None)
        if pidfd_open is not None:
            try:
                fd = pidfd_open(pid)
            except OSError:
                fd = None
        if fd is not None:
            select.select([fd], [], [])
        else:
            while not _process_gone(pid):
                time.sleep(period)
        os._exit(1)

    if _process_gone(pid):
        os._exit(1)
    threading.Thread(target=watch, name="odorloc-parent-watch", daemon=True).start()


def warm_kernels() -> None:
    """Load the compiled kernels now (:func:`odorloc.core.jit.warm`), so that a worker's first
    episode is not slower than the others; a failure here only costs that speed."""
    try:
        from odorloc.core.jit import warm

        warm()
    except Exception:  # an optimisation only: the episode compiles what it needs
        pass


def ignore_interrupts() -> None:
    """Worker set-up: ignore SIGINT (the parent that started the worker stops it)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


WORKER_SETUP = "odorloc-worker-setup"
"""Name of the Dask worker plugin that sets each worker up (see :func:`dask_worker_setup`)."""


def dask_worker_setup(ignore_sigint: bool) -> Any:
    """A Dask worker plugin that sets up every worker of the cluster, present and future.

    Its ``setup`` runs on each worker when the plugin is registered and again on every worker
    that joins later, among them those Dask starts in place of a worker that died (segfault,
    out of memory) or restarts: set-up done once with ``Client.run`` would reach only the
    workers present at that moment, and a restarted worker would then die noisily on Ctrl-C and
    compile or load its kernels during its first episode.

    Parameters
    ----------
    ignore_sigint : bool
        Ignore SIGINT (:func:`ignore_interrupts`); only for workers this process started and
        stops itself.

    Returns
    -------
    distributed.WorkerPlugin
        The plugin, named :data:`WORKER_SETUP`; always loads the kernels (:func:`warm_kernels`).
    """
    from distributed import WorkerPlugin

    # defined here so that importing this module does not import distributed (an extra); the
    # class is shipped to the workers by value
    class OdorlocWorkerSetup(WorkerPlugin):
        name = WORKER_SETUP

        def __init__(self, ignore_sigint: bool) -> None:
            self.ignore_sigint = ignore_sigint

        def setup(self, worker: Any) -> None:
            if self.ignore_sigint:
                ignore_interrupts()
            warm_kernels()

    return OdorlocWorkerSetup(ignore_sigint)


def init_worker(parent_pid: int) -> None:
    """Initializer of a local pool worker: watch the parent, then load the kernels."""
    watch_parent(parent_pid)
    warm_kernels()


class LocalBackend:
    """A process pool on this machine.

    Parameters
    ----------
    workers : int
        Worker processes; ``1`` runs the episodes in the calling process.
    mp_context : str, optional
        Start method; default ``"forkserver"`` where available (safe with the progress thread,
        cheaper than ``"spawn"``), else ``"spawn"``.
    """

    def __init__(self, workers: int = 2, mp_context: str | None = None) -> None:
        if workers < 1:
            raise ConfigError("workers", f"must be >= 1, got {workers}")
        self.workers = workers
        if mp_context is None:
            methods = multiprocessing.get_all_start_methods()
            mp_context = "forkserver" if "forkserver" in methods else "spawn"
        self.mp_context = mp_context
        self._pool: ProcessPoolExecutor | None = None

    def _new_pool(self) -> ProcessPoolExecutor:
        ctx = multiprocessing.get_context(self.mp_context)
        return ProcessPoolExecutor(
            max_workers=self.workers,
            mp_context=ctx,
            initializer=init_worker,
            initargs=(os.getpid(),),
        )

    def __enter__(self) -> LocalBackend:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Shut the pool down, cancelling work not yet started."""
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None

    def run(
        self,
        tasks: Iterable[Any],
        episode_fn: Callable[[Any], Any],
        keep_arrays: bool = False,
        chunk_size: int | None = None,
        groups: Iterable[Sequence[Any]] | None = None,
        total: int | None = None,
    ) -> Iterator[TaskRow]:
        """Yield ``(task, row)`` for every task, in completion order.

        ``tasks`` may be a lazy iterable (it is consumed as work is sent out; ``total``, the
        number of tasks, then sizes the chunks). With ``groups`` (a partition of the tasks,
        also possibly lazy), each group is one work item and ``episode_fn`` is a group
        function (see :func:`run_chunk`).
        """
        grouped = groups is not None
        chunks: Iterator[list[Any]]
        if grouped:
            chunks = (list(g) for g in groups)  # type: ignore[union-attr]
        else:
            size = chunk_size or default_chunk_size(_count(tasks, total), self.workers)
            chunks = _chunks(tasks, size)
        if self.workers == 1:
            for chunk in chunks:
                yield from zip(
                    chunk, run_chunk(episode_fn, chunk, keep_arrays, grouped), strict=True
                )
            return
        while True:
            suspects: list[list[Any]] = []
            yield from self._run_chunks(chunks, episode_fn, keep_arrays, suspects, grouped)
            if suspects:
                # a worker died (segfault, os._exit, out of memory): rerun the episodes that
                # were in flight one per work item (one group per item), so a repeat offender
                # is isolated and recorded as an error; then go on with the rest
                yield from self._run_isolated(suspects, episode_fn, keep_arrays, grouped)
            nxt = next(chunks, None)
            if nxt is None:
                return
            chunks = itertools.chain([nxt], chunks)

    def _run_chunks(
        self,
        queue: Iterator[list[Any]],
        episode_fn: Callable[[Any], Any],
        keep_arrays: bool,
        suspects: list[list[Any]],
        grouped: bool,
    ) -> Iterator[TaskRow]:
        """Run chunks from ``queue`` until it is empty or the pool breaks (then the chunks in
        flight go to ``suspects`` and the rest of the queue is left for the caller)."""
        if self._pool is None:
            self._pool = self._new_pool()
        inflight: dict[Future, list[Any]] = {}
        max_inflight = 2 * self.workers + 1
        broken = False

        def submit() -> None:
            while len(inflight) < max_inflight:
                chunk = next(queue, None)
                if chunk is None:
                    return
                assert self._pool is not None
                fut = self._pool.submit(run_chunk, episode_fn, chunk, keep_arrays, grouped)
                inflight[fut] = chunk

        submit()
        while inflight:
            finished, _ = wait(inflight, return_when=FIRST_COMPLETED)
            for fut in finished:
                chunk = inflight.pop(fut)
                try:
                    rows = fut.result()
                except BrokenProcessPool:
                    broken = True
                    suspects.extend([chunk] if grouped else [[t] for t in chunk])
                    continue
                yield from zip(chunk, rows, strict=True)
            if not broken:
                submit()
        if broken:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None

    def _run_isolated(
        self,
        items: list[list[Any]],
        episode_fn: Callable[[Any], Any],
        keep_arrays: bool,
        grouped: bool,
    ) -> Iterator[TaskRow]:
        for item in items:
            pool = self._new_pool()
            try:
                rows = pool.submit(run_chunk, episode_fn, item, keep_arrays, grouped).result()
            except BrokenProcessPool:
                rows = died_rows(len(item))
            finally:
                pool.shutdown(wait=True)
            yield from zip(item, rows, strict=True)


def _check_scheduler_address(address: str) -> None:
    """Refuse an address Dask cannot parse (:class:`ConfigError` naming ``scheduler``)."""
    from distributed.comm.addressing import parse_address, parse_host_port
    from distributed.comm.registry import get_backend

    try:
        scheme, loc = parse_address(address, strict=True)
        get_backend(scheme)
        if scheme != "inproc":
            port = parse_host_port(loc)[1]
            if not 0 < port < 65536:
                raise ValueError(f"port {port} is not in 1-65535")
    except ValueError as exc:
        raise ConfigError(
            "scheduler",
            f"expected an address like tcp://host:8786, got {address!r} ({exc})",
        ) from None


class DaskBackend:
    """A Dask ``distributed`` cluster.

    Parameters
    ----------
    workers : int
        Worker processes of the ``LocalCluster`` started when no ``scheduler`` is given (one
        thread each, so episodes do not compete for the GIL).
    scheduler : str, optional
        Address of a running scheduler, ``"tcp://host:port"``; a malformed one raises
        :class:`ConfigError` before any connection is tried.
    timeout : float, seconds
        Connection timeout; an unreachable scheduler raises :class:`ConfigError`.

    Notes
    -----
    The workers of a ``LocalCluster`` started here ignore SIGINT: Ctrl-C stops the sweep in
    this process, which then shuts them down (workers of a cluster joined by address are left
    as they are). Every worker loads the compiled kernels before its first episode. Both are
    done by a worker plugin (:func:`dask_worker_setup`), so they also reach the workers Dask
    starts later in place of one that died or was restarted.
    """

    def __init__(self, workers: int = 2, scheduler: str | None = None, timeout: float = 5.0):
        if workers < 1:
            raise ConfigError("workers", f"must be >= 1, got {workers}")
        if scheduler is not None and "://" not in scheduler:
            raise ConfigError(
                "scheduler", f"expected an address like tcp://host:8786, got {scheduler!r}"
            )
        self.workers = workers
        self.scheduler = scheduler
        self.timeout = timeout
        self._client: Any = None
        self._cluster: Any = None

    def __enter__(self) -> DaskBackend:
        try:
            import distributed
        except ImportError:
            raise ConfigError(
                "backend", "the dask backend needs the extra: pip install 'odorloc[dask]'"
            ) from None
        import logging

        if self.scheduler is not None:
            # a malformed address fails deep inside the client, and the half-built client then
            # blocks at exit trying to close: refuse it before connecting
            _check_scheduler_address(self.scheduler)
            try:
                self._client = distributed.Client(
                    self.scheduler, timeout=self.timeout, set_as_default=False
                )
            except ValueError as exc:
                raise ConfigError(
                    "scheduler", f"not a Dask scheduler address: {self.scheduler!r} ({exc})"
                ) from None
            except (OSError, TimeoutError) as exc:
                reason = str(exc).splitlines()[0][:120] if str(exc) else type(exc).__name__
                raise ConfigError(
                    "scheduler",
                    f"cannot reach Dask scheduler {self.scheduler} within {self.timeout:g} s "
                    f"({reason})",
                ) from None
        else:
            self._cluster = distributed.LocalCluster(
                n_workers=self.workers,
                threads_per_worker=1,
                processes=True,
                dashboard_address=None,
                silence_logs=logging.ERROR,
                # an item whose worker died is run again alone, one episode per item (see
                # run): Dask's own retries would only kill more workers first
                scheduler_kwargs={"allowed_failures": 0},
            )
            try:
                self._client = distributed.Client(self._cluster, set_as_default=False)
            except BaseException:
                self.close()
                raise
        try:
            # Ctrl-C reaches the whole process group: the workers of a cluster started here
            # ignore it, so that this process shuts them down instead of each dying on the
            # signal with its own tracebacks; a plugin (not Client.run) so that workers Dask
            # restarts get it too
            self._client.register_plugin(dask_worker_setup(ignore_sigint=self._cluster is not None))
        except BaseException:
            # a failure (or Ctrl-C) part-way must not leave a cluster of our own running
            self.close()
            raise
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Disconnect; a cluster started here is shut down."""
        if self._client is not None:
            if self._cluster is None:
                # a cluster joined by address is left as it was found
                with contextlib.suppress(Exception):
                    self._client.unregister_worker_plugin(WORKER_SETUP)
            self._client.close()
            self._client = None
        if self._cluster is not None:
            self._cluster.close()
            self._cluster = None

    @property
    def n_workers(self) -> int:
        """Workers currently connected to the scheduler."""
        return len(self._client.scheduler_info()["workers"]) if self._client else 0

    @property
    def client(self) -> Any:
        """The ``distributed.Client`` while the backend is open (``None`` otherwise): to run
        something of one's own on the same workers."""
        return self._client

    @property
    def cluster(self) -> Any:
        """The local cluster this backend started (``None`` when it joined a scheduler by
        address, or once closed)."""
        return self._cluster

    def run(
        self,
        tasks: Iterable[Any],
        episode_fn: Callable[[Any], Any],
        keep_arrays: bool = False,
        chunk_size: int | None = None,
        groups: Iterable[Sequence[Any]] | None = None,
        total: int | None = None,
    ) -> Iterator[TaskRow]:
        """Yield ``(task, row)`` for every task, as the chunks finish (``as_completed``).

        ``tasks``, ``groups`` and ``total`` as for :meth:`LocalBackend.run`.
        """
        import distributed

        if self._client is None:
            raise RuntimeError("use DaskBackend as a context manager")
        n_workers = max(1, self.n_workers or self.workers)
        grouped = groups is not None
        if grouped:
            queue: Iterator[list[Any]] = (list(g) for g in groups)  # type: ignore[union-attr]
        else:
            size = chunk_size or default_chunk_size(_count(tasks, total), n_workers)
            queue = _chunks(tasks, size)
        # work item key -> (tasks, whether they already ran alone after a worker died)
        chunk_of: dict[str, tuple[list[Any], bool]] = {}
        isolate: collections.deque[list[Any]] = collections.deque()
        max_inflight = 2 * n_workers + 1
        ac = distributed.as_completed(loop=self._client.loop)

        def submit(chunk: list[Any], alone: bool) -> None:
            fut = self._client.submit(
                run_chunk, episode_fn, chunk, keep_arrays, grouped, pure=False
            )
            chunk_of[fut.key] = (chunk, alone)
            ac.add(fut)

        def fill() -> None:
            if isolate:
                # suspects run one at a time with nothing else in flight: a worker that dies
                # then names its episode (Dask also fails the items queued on that worker)
                if not chunk_of:
                    submit(isolate.popleft(), True)
                return
            while len(chunk_of) < max_inflight:
                chunk = next(queue, None)
                if chunk is None:
                    return
                submit(chunk, False)

        fill()
        for fut in ac:
            chunk, alone = chunk_of.pop(fut.key)
            try:
                rows = fut.result()
            except distributed.KilledWorker:
                # the worker holding this item died (segfault, os._exit, out of memory): as
                # the local pool does, run its episodes again one per item, so that only a
                # repeat offender is recorded as an error
                if alone:
                    rows = died_rows(len(chunk))
                else:
                    isolate.extend([chunk] if grouped else [[t] for t in chunk])
                    rows = []
                    chunk = []
            fut.release()
            fill()
            yield from zip(chunk, rows, strict=True)


def make_backend(
    name: str, workers: int = 2, scheduler: str | None = None, timeout: float = 5.0
) -> LocalBackend | DaskBackend:
    """A backend by name: ``"local"`` or ``"dask"``."""
    if name == "local":
        return LocalBackend(workers=workers)
    if name == "dask":
        return DaskBackend(workers=workers, scheduler=scheduler, timeout=timeout)
    raise ConfigError("backend", f"unknown backend {name!r} (known: local, dask)")
