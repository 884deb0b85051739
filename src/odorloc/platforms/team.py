"""Team communication: who can hear whom, message delivery and byte accounting.

Agents within ``radius`` metres of each other (Euclidean distance, inclusive) are neighbours;
the graph is recomputed from the positions at every delivery. A payload broadcast by an agent
reaches every neighbour, and its size is charged once per recipient (the unicast reading of
"data transmitted to neighbouring UAVs", eq. 8 of the multi-UAV paper): that is what
:attr:`CommGraph.bytes_sent` and :attr:`CommGraph.bytes_total` count. Radius 0 means no
communication at all (even between co-located agents); ``inf`` connects everybody.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike

from odorloc.core.errors import ConfigError
from odorloc.core.types import ArrayPayload, Message, Payload

Sent = Payload | Mapping[str, ArrayLike]
"""What a sender may pass: a typed :class:`~odorloc.core.types.Payload`, or a dict of named
arrays (taken as an :class:`~odorloc.core.types.ArrayPayload`)."""


def _payload_array(value: ArrayLike, field: str) -> np.ndarray:
    """``value`` as a new array whose ``nbytes`` is what a radio would send.

    Raises
    ------
    ConfigError
        When ``value`` is not a rectangular array of numbers, booleans or bytes/text: an object
        array (nested dicts, ragged lists, ``None``) has no size in bytes to count, only the
        size of its pointers.
    """
    try:
        a = np.array(value)
    except (TypeError, ValueError):
        raise ConfigError(
            field, f"must be a rectangular array of numbers, got a ragged {type(value).__name__}"
        ) from None
    if a.dtype.hasobject:
        raise ConfigError(
            field, f"must be an array of numbers, not of Python objects ({type(value).__name__})"
        )
    return a


def as_payload(payload: Sent, field: str = "payload") -> Payload:
    """``payload`` as a typed :class:`~odorloc.core.types.Payload` (a dict of named arrays
    becomes an :class:`~odorloc.core.types.ArrayPayload` of read-only copies).

    Raises :class:`~odorloc.core.errors.ConfigError` (field ``<field>.<name>``) for a value
    that is not an array of numbers (e.g. a nested dict), whose size cannot be counted, and for
    anything that is neither a payload nor a dict.
    """
    if isinstance(payload, Payload):
        return payload
    if not isinstance(payload, Mapping):
        raise ConfigError(field, "must be a Payload or a dict of name -> array")
    return ArrayPayload({str(k): _payload_array(v, f"{field}.{k}") for k, v in payload.items()})


def message_nbytes(payload: Sent) -> int:
    """Size of a payload in bytes: its declared size (a dict of arrays: their ``nbytes``).

    Raises :class:`~odorloc.core.errors.ConfigError` (field ``payload.<name>``) for a value
    that is not an array of numbers (e.g. a nested dict), whose size cannot be counted.

    Examples
    --------
    A Gaussian summary of a 3D belief (mean + covariance, 12 float64 numbers) is 96 bytes.
    """
    return int(as_payload(payload).nbytes)


def _positions(positions: ArrayLike) -> np.ndarray:
    """``positions`` as a new ``(N, d)`` float array of finite coordinates (metres)."""
    p = np.array(positions, dtype=float)
    if p.ndim != 2:
        raise ConfigError("positions", f"expected shape (N, d), got {p.shape}")
    if not np.all(np.isfinite(p)):
        bad = int(np.flatnonzero(~np.all(np.isfinite(p), axis=1))[0])
        raise ConfigError("positions", f"agent {bad} has a non-finite coordinate")
    return p


def _agent_index(agent: int, n: int) -> int:
    """``agent`` checked to be an agent index in ``[0, n)`` (a negative index would silently
    answer for another agent, counted from the end)."""
    if isinstance(agent, bool) or not (isinstance(agent, int | np.integer) and 0 <= agent < n):
        raise ConfigError("agent", f"must be an agent index in [0, {n}), got {agent!r}")
    return int(agent)


def neighbour_matrix(positions: ArrayLike, radius: float) -> np.ndarray:
    """Adjacency of agents within ``radius`` of each other.

    Parameters
    ----------
    positions : (N, d) array_like, metres
    radius : float, metres
        Communication radius; 0 = nobody, ``inf`` = everybody.

    Returns
    -------
    (N, N) bool ndarray
        Symmetric, ``False`` on the diagonal.

    Raises
    ------
    ConfigError
        For a negative or NaN ``radius`` or a non-finite position: compared as they are, a
        negative radius would connect agents within ``|radius|`` and a NaN coordinate would
        cut an agent off (or, with ``inf``, keep it connected) without a word.
    """
    r = float(radius)
    if math.isnan(r) or r < 0:
        raise ConfigError("radius", f"must be >= 0 (inf for all-to-all), got {radius}")
    p = _positions(positions)
    n = len(p)
    if r == 0.0:
        return np.zeros((n, n), dtype=bool)
    if math.isinf(r):
        adj = np.ones((n, n), dtype=bool)
    else:
        diff = p[:, None, :] - p[None, :, :]
        adj = np.einsum("ijk,ijk->ij", diff, diff) <= r * r
    np.fill_diagonal(adj, False)
    return adj


class CommGraph:
    """The neighbour graph of a team and the message exchange over it.

    Parameters
    ----------
    radius : float, metres
        Communication radius (>= 0; ``inf`` for all-to-all).

    Attributes
    ----------
    bytes_total : int
        Bytes delivered since :meth:`reset`, counted once per recipient.
    bytes_sent, bytes_received : (N,) int64 ndarray
        Per-agent bytes sent (summed over recipients) and received.
    messages_delivered : int
        Message copies delivered (one per recipient).
    last_sent : (N,) int64 ndarray
        Bytes each agent sent at the last :meth:`deliver`.
    """

    def __init__(self, radius: float) -> None:
        r = float(radius)
        if math.isnan(r) or r < 0:
            raise ConfigError("comm_radius", f"must be >= 0 (inf for all-to-all), got {radius}")
        self.radius = r
        self._n: int | None = None
        self.reset()

    def reset(self) -> None:
        """Forget the graph and zero the accounting."""
        self._n = None
        self._adjacency: np.ndarray | None = np.zeros((0, 0), dtype=bool)
        self._graph_positions: np.ndarray | None = None
        self.bytes_total = 0
        self.messages_delivered = 0
        self.bytes_sent = np.zeros(0, dtype=np.int64)
        self.bytes_received = np.zeros(0, dtype=np.int64)
        self.last_sent = np.zeros(0, dtype=np.int64)
        self._last_key: tuple[np.ndarray, Mapping[int, Payload]] | None = None

    def _size(self, n: int) -> None:
        if self._n is None:
            self._n = n
            self.bytes_sent = np.zeros(n, dtype=np.int64)
            self.bytes_received = np.zeros(n, dtype=np.int64)
            self.last_sent = np.zeros(n, dtype=np.int64)
        elif n != self._n:
            raise ConfigError("positions", f"team size changed from {self._n} to {n}; reset()")

    @property
    def adjacency(self) -> np.ndarray:
        """``(N, N)`` bool neighbour matrix of the last :meth:`update` or :meth:`deliver`."""
        if self._adjacency is None:
            # a delivery without messages only noted the positions
            self._adjacency = neighbour_matrix(self._graph_positions, self.radius)
        return self._adjacency

    def update(self, positions: ArrayLike) -> np.ndarray:
        """Recompute the neighbour graph from ``(N, d)`` positions; return the ``(N, N)`` matrix."""
        self._adjacency = neighbour_matrix(positions, self.radius)
        self._size(len(self._adjacency))
        return self._adjacency

    def neighbours(self, agent: int) -> np.ndarray:
        """Indices of ``agent``'s neighbours in the current graph, ascending."""
        adj = self.adjacency
        return np.flatnonzero(adj[_agent_index(agent, len(adj))])

    def degree(self) -> np.ndarray:
        """Number of neighbours per agent, ``(N,)``."""
        return self.adjacency.sum(axis=1)

    def _payloads(self, messages: Mapping[int, Sent], n: int) -> dict[int, Payload]:
        out: dict[int, Payload] = {}
        for k, payload in messages.items():
            if isinstance(k, bool) or not (isinstance(k, int | np.integer) and 0 <= int(k) < n):
                raise ConfigError("messages", f"sender {k!r} is not an agent index in [0, {n})")
            # typed payloads hold read-only copies; a dict's arrays are copied here, so later
            # changes by the sender never reach receivers
            out[int(k)] = as_payload(payload, f"messages[{k}]")
        return out

    def deliver(
        self, positions: ArrayLike, messages: Mapping[int, Sent]
    ) -> tuple[list[tuple[Message, ...]], int]:
        """Update the graph from ``positions`` and deliver each agent's payload to its neighbours.

        Parameters
        ----------
        positions : (N, d) array_like, metres
            Positions at the time of sending.
        messages : dict of int to dict of str to array_like
            Payload broadcast by each sending agent.

        Returns
        -------
        inbox : list of tuple of Message
            For each agent, the messages it received, ordered by sender.
        nbytes : int
            Bytes delivered by this call (payload size times number of recipients, summed).
        """
        if not messages:
            # nothing to deliver (most control steps): the graph is computed only if asked for
            p = _positions(positions)
            n = len(p)
            self._size(n)
            self._adjacency, self._graph_positions = None, p
            self.last_sent = np.zeros(n, dtype=np.int64)
            self._last_key = (p, messages)
            return [() for _ in range(n)], 0
        adj = self.update(positions)
        n = len(adj)
        payloads = self._payloads(messages, n)
        inbox: list[list[Message]] = [[] for _ in range(n)]
        sent = np.zeros(n, dtype=np.int64)
        for k in sorted(payloads):
            msg = Message(k, payloads[k])
            size = msg.nbytes
            to = np.flatnonzero(adj[k])
            for j in to:
                inbox[j].append(msg)
            sent[k] = size * len(to)
            self.bytes_received[to] += size
            self.messages_delivered += len(to)
        self.bytes_sent += sent
        self.last_sent = sent
        total = int(sent.sum())
        self.bytes_total += total
        self._last_key = (np.array(positions, dtype=float), messages)
        return [tuple(b) for b in inbox], total

    def bytes_sent_by(
        self,
        agent: int,
        positions: ArrayLike | None = None,
        messages: Mapping[int, Sent] | None = None,
    ) -> int:
        """Bytes ``agent`` sends (summed over recipients) for ``messages`` at ``positions``.

        Without arguments, or with those of the last :meth:`deliver`, this is the amount charged
        at that delivery; otherwise it is computed without touching the accounting. Use it to
        charge the sender's communication energy (eq. 8, multi-UAV paper).
        """
        if positions is None and messages is None:
            if self._n is None:
                return 0
            return int(self.last_sent[_agent_index(agent, self._n)])
        if positions is None or messages is None:
            raise ConfigError("positions", "give both positions and messages, or neither")
        key = self._last_key
        p = _positions(positions)
        agent = _agent_index(agent, len(p))
        if key is not None and messages is key[1] and np.array_equal(p, key[0]):
            return int(self.last_sent[agent])
        if agent not in messages:
            return 0
        adj = neighbour_matrix(p, self.radius)
        return message_nbytes(messages[agent]) * int(adj[agent].sum())
