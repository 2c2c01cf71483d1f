"""The rules of outputs: what may be written where, checked before anything is read (docs/security.md, "Outputs").

* :func:`check_outputs` checks a command's outputs: their names (extension, the file system's limits on a name and a
  path, not a temporary's), that none is an input (the same path, the same file through a link or a hard link, a
  folder holding an input, a place inside an input's rosbag2 folder) or another of the outputs, and that an existing
  one may be replaced: only with ``force``, and only when it is of the kind tfrec writes there.
* An :class:`OutputKind` recognizes what tfrec writes: a :class:`FileKind` a file by its first bytes (MCAP's magic,
  ``#ROSBAG V2.0``, Rerun's ``RRF2``, PNG's signature…), a folder kind (a rosbag2 bag:
  :data:`tfrec.formats.kinds.ROSBAG2`) the entries it would remove. Anything else is refused with one line and
  never replaced: a file of another kind, an empty file (tfrec writes none, but a JSON-lines report of a run
  stopped before its first row), a folder holding anything else, a symbolic link, a folder where a file goes.
* Temporaries are named ``.tfrec-<namespace>-<pid>-<8 hex digits>[.ext]`` (:func:`temporary_name`: at most 51
  bytes, whatever the target's name, so that a 255-byte output name works). Those a killed run left are removed
  only when the name says this machine and PID namespace, the process is gone, and what they hold can only be an
  unfinished output (:func:`stale_temporaries`).

:class:`tfrec._atomic.AtomicOutputs` writes the outputs and checks an existing target again when it replaces it.
"""

from __future__ import annotations

import functools
import os
import re
import stat
import uuid
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Protocol, final

from tfrec.errors import WriteError

__all__ = [
    "NAME_MAX",
    "PATH_MAX",
    "REPLACES",
    "STALE",
    "FileKind",
    "NotOurs",
    "OutputKind",
    "check_existing",
    "check_outputs",
    "check_path_length",
    "check_target",
    "process_namespace",
    "read_head",
    "refusal",
    "stale_temporaries",
    "temporary_name",
]

NAME_MAX = 255
"""Bytes of one file name, where the file system does not say (Linux's ext4, XFS, btrfs, tmpfs)."""
PATH_MAX = 4096
"""Bytes of a path handed to the system, with its terminating NUL (Linux)."""
REPLACES = "`force` replaces only what tfrec writes there"
"""The end of every refusal to replace an existing output."""


class NotOurs(Exception):
    """Raised by :meth:`OutputKind.owned`: an existing path is not of the kind; the message is the reason
    (``it holds notes.txt, which its metadata.yaml does not list``)."""


class OutputKind(Protocol):
    """What tfrec writes at one output: how it is named, and how an existing one is recognized."""

    @property
    def name(self) -> str:
        """For messages, with its article: ``an MCAP file``, ``a rosbag2 folder``."""

    @property
    def folder(self) -> bool:
        """The output is a folder (written as a temporary folder, replaced entry by entry)."""

    @property
    def suffix(self) -> str | None:
        """The extension a target's name must end in (None: any; the caller checks it)."""

    def owned(self, target: Path) -> list[Path]:
        """The paths tfrec removes to replace the existing ``target`` (a file: itself; a folder: its entries).

        Raises:
            NotOurs: ``target`` is not of this kind (the message says why).
        """

    def inner_names(self, target: Path) -> tuple[str, ...]:
        """The names a folder output creates inside itself (their length is checked); () for a file."""

    def unfinished(self, path: Path) -> bool:
        """Whether ``path`` can be what a run writing this kind left when it was killed: a regular file that is
        empty or begins as the kind does; a folder holding nothing but such entries. Anything else is not removed
        as a stale temporary, whatever its name."""


@final
@dataclass(frozen=True, slots=True)
class FileKind:
    """A kind of file, recognized by its first bytes.

    Attributes:
        name: with its article, for messages (``a Rerun recording``).
        signatures: the file starts with one of these (none: no signature; ``test`` decides).
        suffix: the extension a target's name must end in, or None.
        empty: an empty file is one (tfrec writes no empty file, but a report of a run stopped before its first row).
        test: a further check of a file that has a signature, given its path and first :data:`HEAD` bytes: the
            reason it is not one, or None.
    """

    name: str
    signatures: tuple[bytes, ...] = ()
    suffix: str | None = None
    empty: bool = False
    test: Callable[[Path, bytes], str | None] | None = None
    folder: bool = field(default=False, init=False)

    HEAD = 4096
    """Bytes read of an existing file to recognize it."""

    def owned(self, target: Path) -> list[Path]:
        """``[target]`` when it is a regular file of this kind.

        Raises:
            NotOurs: a file of another kind, not a regular file, or empty.
        """
        head = read_head(target, self.HEAD)
        if not head:
            if self.empty:
                return [target]
            raise NotOurs("it is empty")
        if self.signatures and not head.startswith(self.signatures):
            raise NotOurs(f"it does not begin as {self.name} does")
        reason = self.test(target, head) if self.test is not None else None
        if reason is not None:
            raise NotOurs(reason)
        return [target]

    def inner_names(self, target: Path) -> tuple[str, ...]:
        return ()

    def unfinished(self, path: Path) -> bool:
        """A regular file, empty or beginning with a signature of the kind (a kind without one: nothing is)."""
        try:
            head = read_head(path, self.HEAD)
        except NotOurs:
            return False
        return not head or bool(self.signatures and head.startswith(self.signatures))


def read_head(path: Path, size: int) -> bytes:
    """The first ``size`` bytes of a regular file, never following a link nor opening a FIFO or device.

    Raises:
        NotOurs: ``path`` is not a regular file, or cannot be read.
    """
    try:
        mode = os.lstat(path).st_mode
        if not stat.S_ISREG(mode):
            raise NotOurs("it is a symbolic link" if stat.S_ISLNK(mode) else "it is not a regular file")
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0))
        with os.fdopen(fd, "rb") as stream:
            return stream.read(size)
    except OSError as err:
        raise NotOurs(f"it cannot be read: {err.strerror or err}") from err


def refusal(target: Path | str, kind: OutputKind, reason: str) -> WriteError:
    """The one-line error of an existing ``target`` that is not of ``kind``."""
    return WriteError(f"{target}: exists and is not {kind.name} ({reason}): {REPLACES}")


def check_target(target: Path, kind: OutputKind, *, force: bool,
                 inputs: Iterable[str | os.PathLike[str] | None] = ()) -> None:
    """:func:`check_outputs` for one output."""
    check_outputs([(target, kind)], force=force, inputs=inputs)


def check_outputs(outputs: Sequence[tuple[Path, OutputKind]], *, force: bool,
                  inputs: Iterable[str | os.PathLike[str] | None] = ()) -> None:
    """Check a command's outputs before anything is read or written.

    Args:
        outputs: each output and its kind.
        force: an existing output of its kind may be replaced.
        inputs: what the command reads (recordings, descriptions, CSV files; None entries are skipped).

    Raises:
        WriteError: one line naming the output (and the input): a name with the wrong extension, longer than the
            file system allows or named like tfrec's temporaries; an output that is an input, holds one or lies
            in an input's rosbag2 folder; two outputs at one place; an existing output without ``force``, or
            one that is not of its kind (a symbolic link, a folder where a file goes, a file of another kind, a
            folder holding anything else).
    """
    given = [os.fspath(path) for path in inputs if path is not None]
    for path in given:
        check_path_length(path, what="input")
    for target, kind in outputs:
        _check_name(target, kind)
    _check_distinct(outputs)
    if given:
        guard = _InputGuard(given)
        for target, _ in outputs:
            guard.check(target)
    for target, kind in outputs:
        check_existing(target, kind, force=force)


def check_path_length(path: str | os.PathLike[str], *, what: str = "output") -> None:
    """A path the system can take: no name longer than the file system's limit, the whole under PATH_MAX.

    Raises:
        WriteError: one line naming the path (shortened) and the limit.
    """
    raw = os.fsencode(path)
    if len(raw) >= PATH_MAX:
        raise WriteError(f"{_shortened(path)}: the {what}'s path has {len(raw):,} bytes; the system takes at most "
                         f"{PATH_MAX - 1:,}")
    limit = _name_max(os.path.dirname(os.fsdecode(raw)))
    for part in raw.split(b"/"):
        if len(part) > limit:
            raise WriteError(f"{os.fspath(path)}: a name in the {what}'s path has {len(part):,} bytes; the file "
                             f"system allows at most {limit}")


def _shortened(path: str | os.PathLike[str]) -> str:
    text = os.fspath(path)
    return text if len(text) <= 120 else f"{text[:60]}…{text[-50:]}"


@functools.lru_cache(maxsize=64)
def _name_max(folder: str) -> int:
    """The longest file name (bytes) in ``folder``, or in its nearest existing parent (asked once per folder:
    ``check`` checks thousands of recordings in a few)."""
    path = Path(folder)
    for place in (path, *path.parents):
        try:
            return int(os.pathconf(place if str(place) else ".", "PC_NAME_MAX"))
        except (OSError, ValueError):
            continue
    return NAME_MAX


def _check_name(target: Path, kind: OutputKind) -> None:
    if kind.suffix is not None and target.suffix != kind.suffix:
        raise WriteError(f"{target}: the output's name must end in {kind.suffix} ({kind.name})")
    if _is_temporary(target.name):
        raise WriteError(f"{target}: named like tfrec's temporary files, which later runs remove: choose another name")
    check_path_length(target)
    temp = target.parent / ("." + _MARK + "4194304-00000000" + _temp_suffix(target))  # the longest temporary
    check_path_length(temp)
    limit = _name_max(str(target.parent))
    for inner in kind.inner_names(target):
        size = len(os.fsencode(inner))
        if size > limit:  # a rosbag2 folder's storage file is named after the folder
            spare = limit - (size - len(os.fsencode(target.name)))
            raise WriteError(f"{target}: too long a name for {kind.name}: the file {inner} "
                             f"it holds would have {size:,} bytes, and the file system allows {limit} (the folder's "
                             f"name may have {spare})")
        for place in (target, temp):
            check_path_length(place / inner)


def _check_distinct(outputs: Sequence[tuple[Path, OutputKind]]) -> None:
    real = [(target, os.path.realpath(target)) for target, _ in outputs]
    for k, (first, one) in enumerate(real):
        for second, other in real[k + 1:]:
            if one == other or _within(one, other) or _within(other, one):
                raise WriteError(f"{second}: is also the output {first} (or holds it, or lies in it): each output "
                                 "needs its own place")


def check_existing(target: Path, kind: OutputKind, *, force: bool) -> None:
    try:
        mode = os.lstat(target).st_mode
    except FileNotFoundError:
        return
    except OSError as err:
        raise WriteError(f"{target}: cannot look at it: {err.strerror or err}") from err
    if stat.S_ISLNK(mode):
        raise WriteError(f"{target}: is a symbolic link; tfrec replaces neither a link nor what it points to: "
                         "remove the link or choose another name")
    if stat.S_ISDIR(mode) != kind.folder:
        raise WriteError(f"{target}: exists and is a {'folder' if stat.S_ISDIR(mode) else 'file'}")
    try:
        kind.owned(target)
    except NotOurs as why:
        raise refusal(target, kind, str(why)) from None
    if not force:
        raise WriteError(f"{target}: already exists (use `force` to overwrite)")


def _within(inner: str, outer: str) -> bool:
    """``inner`` lies strictly inside the folder ``outer`` (both resolved)."""
    return inner != outer and inner.startswith(outer.rstrip(os.sep) + os.sep)


class _InputGuard:
    """The inputs of a command, resolved once: refuses an output that is one, holds one or lies in one's
    rosbag2 folder."""

    def __init__(self, inputs: Sequence[str]) -> None:
        folders: dict[str, str] = {}  # thousands of recordings found by check share a few folders: resolved once
        bags: dict[str, bool] = {}
        self._inputs = [(given, real, _recording_folder(real, bags))
                        for given, real in ((given, _resolved(given, folders)) for given in inputs)]

    def check(self, target: Path) -> None:
        out = os.path.realpath(target)  # through a link too: a link to an input is that input
        for given, real, home in self._inputs:
            if out == real:
                raise WriteError(f"{target}: is the input {given}; an input is never an output")
            if _within(real, out):
                raise WriteError(f"{target}: holds the input {given}; an output never replaces an input")
            if home is not None and _within(out, home):
                raise WriteError(f"{target}: lies inside the rosbag2 folder of the input {given}; an output is "
                                 "never written into an input")
        if os.path.lexists(target):
            self._check_links(target)

    def _check_links(self, target: Path) -> None:
        """An existing output that is an input under another name (a hard link), or a folder holding one."""
        ids = self._input_ids()
        if not ids:
            return
        try:
            inside = os.path.isdir(target) and not os.path.islink(target)
            entries = [Path(e.path) for e in _scan(target, limit=10_000)] if inside else [target]
        except OSError:
            return
        for entry in entries:
            given = ids.get(_file_id(entry))
            if given is not None:
                what = "is the input" if entry == target else f"holds {entry.name}, a hard link of the input"
                raise WriteError(f"{target}: {what} {given}; an input is never an output")

    def _input_ids(self) -> dict[tuple[int, int] | None, str]:
        ids: dict[tuple[int, int] | None, str] = {}
        for given, real, home in self._inputs:
            files = [Path(real)]
            if home is not None:
                try:
                    files += [Path(e.path) for e in _scan(Path(home), limit=10_000)]
                except OSError:
                    pass
            for file in files:
                ids.setdefault(_file_id(file), given)
        ids.pop(None, None)
        return ids


def _resolved(path: str, folders: dict[str, str]) -> str:
    """``os.path.realpath(path)``, with the folders it lies in resolved once for many paths (``folders``)."""
    head, name = os.path.split(os.path.join(os.getcwd(), path))
    if name in ("", ".", ".."):
        return os.path.realpath(path)
    folder = folders.get(head)
    if folder is None:
        folder = folders[head] = os.path.realpath(head)
    full = os.path.join(folder, name)
    return os.path.realpath(full) if os.path.islink(full) else full


def _scan(folder: Path, *, limit: int) -> list[os.DirEntry[str]]:
    with os.scandir(folder) as entries:
        return [entry for _, entry in zip(range(limit), entries)]


def _file_id(path: Path) -> tuple[int, int] | None:
    """(device, inode) of a regular file (through links), or None."""
    try:
        st = os.stat(path)
    except (OSError, ValueError):
        return None
    return (st.st_dev, st.st_ino) if stat.S_ISREG(st.st_mode) else None


def _recording_folder(real: str, bags: dict[str, bool]) -> str | None:
    """The folder an input recording is (a folder), or lies in (a rosbag2 bag's metadata.yaml or storage file);
    ``bags``: whether a folder holds a metadata.yaml, found once per folder."""
    if os.path.isdir(real):
        return real
    parent = os.path.dirname(real)
    if parent not in bags:
        bags[parent] = os.path.isfile(os.path.join(parent, "metadata.yaml"))
    return parent if bags[parent] else None


_MARK = "tfrec-"
STALE = (
    re.compile(r"\.tfrec-([0-9a-f]{8})-(\d+)-[0-9a-f]{8}(?:\.[A-Za-z0-9]{1,16})?"),
    re.compile(r"\.tfrec-(\d+)-[0-9a-f]{8}(?:\.[A-Za-z0-9]{1,16})?"),  # before the process namespace was named
    re.compile(r"\..+\.tmp-(\d+)-[0-9a-f]{8}"),  # tfrec 0.x's, named after the target
)
"""The names of temporaries: ``.tfrec-<namespace>-<pid>-<8 hex digits>[.<the target's extension>]``, and older
ones. Only the first kind is ever removed as stale (:func:`stale_temporaries`): the others do not say whose
process numbers they carry."""


@functools.cache
def process_namespace() -> str:
    """8 hex digits that name this machine's boot and this process's PID namespace: a temporary whose name carries
    them was written by a process whose number means something here (a container or another host sharing the
    folder numbers its processes apart)."""
    import hashlib

    parts = []
    for source in ("/proc/sys/kernel/random/boot_id", "/proc/self/ns/pid"):
        try:
            parts.append(Path(source).read_text().strip() if source.endswith("boot_id") else str(os.stat(source).st_ino))
        except OSError:
            parts.append(os.uname().nodename)
    return hashlib.sha256(":".join(parts).encode()).hexdigest()[:8]


def stale_temporaries(folder: Path, kind: OutputKind, *, alive: Callable[[int], bool]) -> list[Path]:
    """The temporaries in ``folder`` a killed run of this machine and PID namespace left while writing ``kind``:
    named as this process names them, its process gone (``alive`` says), and what they hold no more than an
    unfinished output of the kind (:meth:`OutputKind.unfinished`). A user's file that only looks like one, and the
    temporaries of runs in another container or on another host, are never among them."""
    found: list[Path] = []
    try:
        entries = list(folder.iterdir())
    except OSError:
        return found
    ours = process_namespace()
    for entry in entries:
        match = STALE[0].fullmatch(entry.name)
        if match is None or match.group(1) != ours or alive(int(match.group(2))):
            continue
        if (entry.is_dir() and not entry.is_symlink()) != kind.folder or not kind.unfinished(entry):
            continue
        found.append(entry)
    return found


def _temp_suffix(target: Path) -> str:
    suffix = target.suffix
    return suffix if re.fullmatch(r"\.[A-Za-z0-9]{1,16}", suffix) else ""


def temporary_name(target: Path) -> Path:
    """A new temporary name beside ``target``: short whatever the target's name (51 bytes at most)."""
    return target.parent / f".{_MARK}{process_namespace()}-{os.getpid()}-{uuid.uuid4().hex[:8]}{_temp_suffix(target)}"


def _is_temporary(name: str) -> bool:
    return any(pattern.fullmatch(name) for pattern in STALE)
