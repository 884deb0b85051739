"""The one path by which user files enter odorloc, and the checks on where outputs go.

Scenario and sweep files are read here, and only here, so every one of them is held to the same
limits and every refusal is one :class:`~odorloc.core.errors.ConfigError` line naming the file
and the problem, before any work starts:

- the file must exist, be a regular file and hold at most :data:`MAX_FILE_BYTES` bytes;
- it must be UTF-8 text (a byte-order mark is allowed) without NUL bytes;
- the YAML must be a single document of the safe tags, nested at most :data:`MAX_DEPTH` levels,
  with at most :data:`MAX_ALIASES` anchors and aliases together, at most :data:`MAX_NODES`
  nodes once every alias is expanded (so an alias "bomb" is refused before it is expanded),
  scalars of at most :data:`MAX_SCALAR_CHARS` characters, integer literals of at most
  :data:`MAX_INT_DIGITS` digits, and no key twice in one mapping (PyYAML would silently keep
  the last).

Outputs are checked before the work that produces them: :func:`check_output_dir` and
:func:`check_output_file` refuse a path that is a file where a folder is needed (or the
reverse), that lies under a file, that is a device, that passes through a symbolic-link loop or
a broken link, whose name is longer than the file system allows, or whose folder does not take
new files (a read-only or virtual file system such as ``/proc``: found by creating and at once
removing an empty folder there, the only way to know); they leave every folder as it was.
"""

from __future__ import annotations

import errno
import os
import stat
import tempfile
from pathlib import Path
from typing import Any

import yaml

from odorloc.core.errors import ConfigError

__all__ = [
    "MAX_ALIASES",
    "MAX_DEPTH",
    "MAX_FILE_BYTES",
    "MAX_INT_DIGITS",
    "MAX_NODES",
    "MAX_SCALAR_CHARS",
    "check_output_dir",
    "check_output_file",
    "load_yaml_mapping",
    "parse_yaml",
    "read_text",
]

MAX_FILE_BYTES = 4 * 1024 * 1024
"""Largest scenario or sweep file, bytes."""
MAX_DEPTH = 32
"""Deepest nesting of mappings and lists."""
MAX_ALIASES = 64
"""Most anchors plus aliases in one file."""
MAX_NODES = 200_000
"""Most YAML nodes (scalars, lists, mappings) with every alias expanded."""
MAX_SCALAR_CHARS = 100_000
"""Longest single value, characters."""
MAX_INT_DIGITS = 30
"""Longest integer literal, digits (a seed below ``2**63`` has 19)."""

_INT_TAG = "tag:yaml.org,2002:int"
_MERGE_TAG = "tag:yaml.org,2002:merge"


class _Refused(yaml.MarkedYAMLError):
    """A limit of this module was exceeded at ``problem_mark``."""


class _LimitedLoader(yaml.SafeLoader):
    """PyYAML's safe loader with the limits of the module docstring.

    Depth and alias budgets are enforced while composing (before any object is built), so deep
    nesting never reaches Python's recursion limit and an alias bomb is refused unexpanded.
    """

    def __init__(self, stream: str) -> None:
        super().__init__(stream)
        self._depth = 0
        self._aliases = 0

    def compose_node(self, parent: Any, index: Any) -> Any:
        event = self.peek_event()
        if isinstance(event, yaml.AliasEvent) or getattr(event, "anchor", None) is not None:
            self._aliases += 1
            if self._aliases > MAX_ALIASES:
                raise _Refused(
                    problem=f"more than {MAX_ALIASES} anchors and aliases",
                    problem_mark=event.start_mark,
                )
        self._depth += 1
        try:
            if self._depth > MAX_DEPTH:
                raise _Refused(
                    problem=f"nested more than {MAX_DEPTH} levels deep",
                    problem_mark=event.start_mark,
                )
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1

    def compose_scalar_node(self, anchor: Any) -> Any:
        node = super().compose_scalar_node(anchor)
        if len(node.value) > MAX_SCALAR_CHARS:
            raise _Refused(
                problem=f"a value of {len(node.value)} characters (at most {MAX_SCALAR_CHARS})",
                problem_mark=node.start_mark,
            )
        if node.tag == _INT_TAG:
            digits = sum(c.isalnum() for c in node.value)
            if digits > MAX_INT_DIGITS:
                raise _Refused(
                    problem=f"an integer literal of {digits} digits (at most {MAX_INT_DIGITS})",
                    problem_mark=node.start_mark,
                )
        return node

    def construct_mapping(self, node: Any, deep: bool = False) -> Any:
        if isinstance(node, yaml.MappingNode):
            first: dict[Any, int] = {}
            for key_node, _ in node.value:
                if key_node.tag == _MERGE_TAG:
                    continue
                key = self.construct_object(key_node, deep=True)
                try:
                    seen = first.get(key)
                except TypeError:
                    raise _Refused(
                        problem="a key that is a list or mapping",
                        problem_mark=key_node.start_mark,
                    ) from None
                if seen is not None:
                    raise _Refused(
                        problem=f"duplicate key {key!r} (first given on line {seen + 1})",
                        problem_mark=key_node.start_mark,
                    )
                first[key] = key_node.start_mark.line
        return super().construct_mapping(node, deep=deep)


def _expanded_size(root: Any) -> int:
    """Nodes of a composed YAML graph with aliases expanded (counting stops past the limit).

    Iterative, and each shared node's size is computed once, so a graph that would expand to
    billions of nodes costs as much to measure as its few hundred distinct nodes.
    """
    size: dict[int, int] = {}
    open_: set[int] = set()
    stack: list[tuple[Any, bool]] = [(root, False)]
    while stack:
        node, done = stack.pop()
        key = id(node)
        if key in size:
            continue
        if isinstance(node, yaml.ScalarNode):
            size[key] = 1
            continue
        if isinstance(node, yaml.MappingNode):
            children = [c for pair in node.value for c in pair]
        else:
            children = list(node.value)
        if done:
            open_.discard(key)
            total = 1 + sum(size.get(id(c), 0) for c in children)
            size[key] = min(total, MAX_NODES + 1)
            continue
        if key in open_:
            raise _Refused(problem="a value that contains itself", problem_mark=node.start_mark)
        open_.add(key)
        stack.append((node, True))
        stack.extend((c, False) for c in children if id(c) not in size)
    return size.get(id(root), 0)


def read_text(path: str | Path, what: str = "file") -> str:
    """The UTF-8 text of a user file, after the checks of the module docstring.

    Parameters
    ----------
    path : path
        The file.
    what : str
        What the file is (``"scenario"``, ``"sweep"``): the field the error names.

    Raises
    ------
    ConfigError
        Missing, a folder, unreadable, too large, binary or not UTF-8.
    """
    p = Path(path)
    try:
        if p.is_dir():
            raise ConfigError(what, f"{p} is a folder, not a {what} file")
        if not p.exists():
            raise ConfigError(what, f"file not found: {p}")
        if not p.is_file():
            raise ConfigError(what, f"{p} is not a regular file")
        n = p.stat().st_size
        if n > MAX_FILE_BYTES:
            raise ConfigError(
                what, f"{p} has {n} bytes; a {what} file may have at most {MAX_FILE_BYTES}"
            )
        with p.open("rb") as fh:
            data = fh.read(MAX_FILE_BYTES + 1)
    except OSError as exc:
        raise ConfigError(what, f"cannot read {p}: {exc.strerror or exc}") from None
    if len(data) > MAX_FILE_BYTES:
        raise ConfigError(what, f"{p} is larger than {MAX_FILE_BYTES} bytes")
    if b"\x00" in data:
        raise ConfigError(what, f"{p} is a binary file, not text")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        bad = data[exc.start : exc.start + 1].hex()
        raise ConfigError(
            what, f"{p} is not UTF-8 text (byte 0x{bad} at offset {exc.start})"
        ) from None


def parse_yaml(text: str, source: str = "<text>", what: str = "file") -> Any:
    """Parse one YAML document under the limits of the module docstring.

    Parameters
    ----------
    text : str
        The document.
    source : str
        Where it came from (a path), for the message.
    what : str
        The field the error names.

    Raises
    ------
    ConfigError
        ``"{what}: {source} line N: problem"``.
    """
    loader = _LimitedLoader(text)
    try:
        try:
            node = loader.get_single_node()
            if node is None:
                return None
            n = _expanded_size(node)
            if n > MAX_NODES:
                raise _Refused(
                    problem=f"more than {MAX_NODES} values once its aliases are expanded",
                    problem_mark=node.start_mark,
                )
            return loader.construct_document(node)
        finally:
            loader.dispose()
    except _Refused as exc:
        mark = exc.problem_mark
        where = f" line {mark.line + 1}" if mark is not None else ""
        raise ConfigError(what, f"{source}{where}: {exc.problem}") from None
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        where = f" line {mark.line + 1}" if mark is not None else ""
        problem = ", ".join(str(x) for x in (exc.context, exc.problem) if x) or "invalid syntax"
        raise ConfigError(
            what, f"{source}{where}: not valid YAML: {' '.join(problem.split())}"
        ) from None
    except yaml.YAMLError as exc:
        raise ConfigError(what, f"{source}: not valid YAML: {' '.join(str(exc).split())}") from None
    except RecursionError:
        raise ConfigError(what, f"{source}: nested too deeply") from None
    except ValueError as exc:
        # a literal the constructor cannot convert (e.g. an out-of-range timestamp)
        raise ConfigError(what, f"{source}: invalid value: {' '.join(str(exc).split())}") from None


def load_yaml_mapping(path: str | Path, what: str = "file") -> dict[str, Any]:
    """Read and parse a YAML file that must hold a mapping (a scenario, a sweep).

    Raises
    ------
    ConfigError
        Any problem of :func:`read_text` or :func:`parse_yaml`; an empty file; a document
        that is not a mapping.
    """
    text = read_text(path, what)
    data = parse_yaml(text, str(path), what)
    if data is None:
        raise ConfigError(what, f"{path} is empty")
    if not isinstance(data, dict):
        raise ConfigError(
            what, f"{path} must hold a mapping of settings, not a {type(data).__name__}"
        )
    return data


# ----------------------------------------------------------------------------- outputs


PATH_MAX = 4096
"""Longest output path accepted, bytes (Linux's ``PATH_MAX``)."""


def _name_max(folder: Path) -> int:
    try:
        return int(os.pathconf(folder, "PC_NAME_MAX"))
    except (OSError, ValueError):
        return 255


def _short(name: str) -> str:
    return name if len(name) <= 24 else f"{name[:12]}...{name[-8:]}"


def _deepest_existing(p: Path, field: str) -> tuple[Path, bool]:
    """Walk ``p`` from the root without following it blindly: the deepest component that
    exists and whether that is ``p`` itself.

    Raises
    ------
    ConfigError
        A component is a file (with more to come), a symbolic-link loop, a broken link or
        unreachable, or a name is longer than the file system allows.
    """
    absolute = Path(os.path.abspath(p))
    if len(os.fsencode(str(absolute))) > PATH_MAX:
        raise ConfigError(field, f"{_short(str(p))} is longer than {PATH_MAX} bytes")
    parts = absolute.parts
    cur = Path(parts[0])
    deepest = cur
    exists = True
    for i, name in enumerate(parts[1:], start=1):
        limit = _name_max(deepest)
        if len(os.fsencode(name)) > limit:
            raise ConfigError(
                field,
                f"the name {_short(name)!r} is {len(name)} characters long; the file system "
                f"allows names of at most {limit}",
            )
        cur = cur / name
        if not exists:
            continue
        try:
            st = os.stat(cur)
        except FileNotFoundError:
            if os.path.islink(cur):
                raise ConfigError(field, f"{cur} is a broken symbolic link") from None
            exists = False
            continue
        except NotADirectoryError:
            raise ConfigError(field, f"{p} lies under {deepest}, which is a file") from None
        except OSError as exc:
            if exc.errno == errno.ELOOP:
                raise ConfigError(field, f"{cur} is a symbolic-link loop") from None
            raise ConfigError(field, f"cannot reach {cur}: {exc.strerror or exc}") from None
        if not stat.S_ISDIR(st.st_mode) and i < len(parts) - 1:
            raise ConfigError(field, f"{p} lies under {cur}, which is a file")
        deepest = cur
    return deepest, exists


def _takes_new_files(folder: Path, p: Path, field: str) -> None:
    """Create and remove an empty folder in ``folder``: a read-only or virtual file system
    (``/proc``) or a folder without write permission refuses it."""
    if not os.access(folder, os.W_OK | os.X_OK):
        raise ConfigError(field, f"cannot write into {p}: {folder} is not writable")
    try:
        probe = tempfile.mkdtemp(prefix=".odorloc-check-", dir=folder)
    except OSError as exc:
        raise ConfigError(
            field, f"cannot write into {p}: {folder} takes no new files ({exc.strerror or exc})"
        ) from None
    os.rmdir(probe)


def check_output_dir(path: str | Path, field: str = "--out") -> Path:
    """Check that ``path`` is (or can be created as) a writable folder; leave it as it was.

    Raises
    ------
    ConfigError
        ``field`` names the option: the path is a file or a device, lies under a file, passes
        through a link loop or a broken link, has a name too long for the file system, or its
        folder takes no new files.
    """
    p = Path(path)
    deepest, exists = _deepest_existing(p, field)
    if exists and not deepest.is_dir():
        raise ConfigError(field, f"{p} is a file, not a folder")
    _takes_new_files(deepest, p, field)
    return p


def check_output_file(path: str | Path, field: str = "--out") -> Path:
    """Check that ``path`` can be written as a file (its folder may still be missing).

    Raises
    ------
    ConfigError
        The path is a folder or a device (not a regular file), lies under a file, passes
        through a link loop, has a name too long, or cannot be written.
    """
    p = Path(path)
    deepest, exists = _deepest_existing(p, field)
    if exists:
        st = os.stat(deepest)
        if stat.S_ISDIR(st.st_mode):
            raise ConfigError(field, f"{p} is a folder, not a file")
        if not stat.S_ISREG(st.st_mode):
            raise ConfigError(field, f"{p} is a device or special file, not a regular file")
        if not os.access(p, os.W_OK):  # also false on a read-only file system
            raise ConfigError(field, f"{p} is not writable")
        return p
    _takes_new_files(deepest, p, field)
    return p
