"""Outputs: checked before anything is read, written whole or not at all, never over what tfrec did not write.

One mechanism for every output of every command (docs/security.md, "Outputs"):

* :func:`check_outputs` checks a command's outputs before anything is read: their names (extension, the file
  system's limits on a name and a path), that none is an input (the same path, the same file through a link, a
  folder holding an input, a place inside an input's rosbag2 folder) or another of the outputs, and that an
  existing one may be replaced: only with ``force``, and only when it is of the kind tfrec writes there.
* An :class:`OutputKind` recognizes what tfrec writes: a :class:`FileKind` a file by its first bytes (MCAP's magic,
  ``#ROSBAG V2.0``, Rerun's ``RRF2``, PNG's signature…), a folder kind (a rosbag2 bag:
  :data:`tfrec.formats.kinds.ROSBAG2`) the entries it would remove. Anything else is refused with one line and
  never replaced: a file of another kind, an empty file (tfrec writes none, but a JSON-lines report of a run
  stopped before its first row), a folder holding anything else, a symbolic link, a folder where a file goes.
* :class:`AtomicOutputs` writes each output to a temporary name beside its target and renames all of them
  together when complete; an existing target is checked again at that moment, and a folder is replaced by
  removing only the entries its kind recognized. After an error, Ctrl-C or SIGTERM the temporaries are deleted;
  errors name the targets, never the temporaries.

Temporaries are named ``.tfrec-<pid>-<8 hex digits>[.ext]`` (at most 42 bytes, whatever the target's name, so
that a 255-byte output name works); those of killed runs are removed by the next run into their folder
(:func:`remove_stale_temporaries`).
"""

from __future__ import annotations

import errno
import functools
import os
import re
import shutil
import stat
import uuid
import warnings
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType
from typing import Protocol, final

from tfrec.errors import RecordingError, TfrecError, WriteError

__all__ = [
    "AtomicOutputs",
    "FileKind",
    "NotOurs",
    "OutputKind",
    "check_outputs",
    "check_path_length",
    "check_target",
    "refusal",
    "remove_stale_temporaries",
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
        _check_existing(target, kind, force=force)


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


def _check_existing(target: Path, kind: OutputKind, *, force: bool) -> None:
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


@final
class AtomicOutputs:
    """Temporary outputs beside their targets, renamed together by :meth:`commit`.

    Use it as a context manager and call :meth:`commit` last inside the block; leaving the block
    otherwise deletes the temporaries. Leaving it by an ``OSError`` or a ``TfrecError`` raises an error that
    names the targets, never the temporary names::

        with AtomicOutputs() as outputs:
            write(outputs.path(target, kind=MCAP))
            outputs.commit()
    """

    def __init__(self, *, replace: bool = True) -> None:
        """``replace``: targets that exist at commit time are replaced (``--force``) when they are of their kind;
        without it a target that appeared meanwhile (another process writing the same name) is an error."""
        self._pairs: list[tuple[Path, Path, OutputKind | None]] = []
        self._replace = replace

    def __enter__(self) -> AtomicOutputs:
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 traceback: TracebackType | None) -> None:
        if error is None:
            self.abort()  # left without commit(): nothing is kept
            return
        mapped: TfrecError | None = None
        if isinstance(error, OSError):
            mapped = WriteError(f"{self.target_of(error.filename)}: cannot write: {error.strerror or error}")
        elif isinstance(error, RecordingError):  # a sink's message names its temporary file
            mapped = WriteError(self.with_targets(str(error)))
        elif isinstance(error, TfrecError) and self.with_targets(str(error)) != str(error):
            mapped = type(error)(self.with_targets(str(error)))
        self.abort()
        if mapped is not None:
            raise mapped from error

    def path(self, target: Path, *, kind: OutputKind) -> Path:
        """A temporary name for ``target`` in its folder (created, with its parents); for a folder ``kind`` the
        temporary folder is created too. Temporaries that killed runs (SIGKILL, a power cut) left in that folder
        are removed first, with a warning."""
        self._pairs.append((target, target, None))  # until the temporary exists, errors name the target
        target.parent.mkdir(parents=True, exist_ok=True)
        self._pairs.pop()
        remove_stale_temporaries(target.parent)
        temp = _temporary(target)
        if kind.folder:
            temp.mkdir()
        self._pairs.append((temp, target, kind))
        return temp

    def target_of(self, filename: object) -> str:
        """The output a (temporary) file name stands for, for messages."""
        if filename is None:  # an error of a library that does not say which file (the outputs, then)
            return ", ".join(dict.fromkeys(str(target) for _, target, _ in self._pairs)) or "output"
        name = Path(os.fsdecode(filename))  # type: ignore[arg-type]
        for temp, target, _ in self._pairs:
            if name == temp:
                return str(target)
            if temp in name.parents:
                return str(target / name.relative_to(temp))
        return str(name)

    def with_targets(self, message: str) -> str:
        """``message`` with every temporary path replaced by its target's."""
        for temp, target, _ in self._pairs:
            message = message.replace(str(temp), str(target)).replace(temp.name, target.name)
        return message

    def commit(self) -> None:
        """Rename every temporary to its target; with ``replace``, every existing target is checked first (a
        target that became something tfrec did not write since it was checked is refused, nothing renamed).

        Raises:
            WriteError: without ``replace``, a target exists now (the outputs committed by this call are removed
                again, the temporaries deleted); with it, an existing target not of its kind.
        """
        owned = [self._owned(target, kind) for _, target, kind in self._pairs] if self._replace else []
        done: list[Path] = []
        try:
            for k, (temp, target, _) in enumerate(self._pairs):
                if self._replace:
                    _replace(temp, target, owned[k])
                else:
                    _rename_new(temp, target)
                done.append(target)
        except FileExistsError:
            for path in done:
                if path.is_dir():
                    shutil.rmtree(path, ignore_errors=True)
                else:
                    path.unlink(missing_ok=True)
            clash = self._pairs[len(done)][1]
            self.abort()
            raise WriteError(f"{clash}: already exists (written meanwhile by another process?); "
                             "use `force` to overwrite")
        self._pairs.clear()

    def _owned(self, target: Path, kind: OutputKind | None) -> list[Path] | None:
        """What replacing ``target`` removes (None: nothing is there), checked as :func:`check_outputs` does."""
        if not os.path.lexists(target):
            return None
        error: WriteError | None = None
        if kind is None:
            error = WriteError(f"{target}: exists and is of no known kind: {REPLACES}")
        else:
            try:
                _check_existing(target, kind, force=True)
                return kind.owned(target)
            except WriteError as err:
                error = err
            except NotOurs as why:
                error = refusal(target, kind, str(why))
        self.abort()
        raise error

    def abort(self) -> None:
        """Delete the temporaries not yet renamed (one that could not be created, in a read-only folder say,
        is no error)."""
        for temp, _, _ in self._pairs:
            try:
                if temp.is_dir() and not temp.is_symlink():
                    shutil.rmtree(temp, ignore_errors=True)
                else:
                    temp.unlink(missing_ok=True)
            except OSError:
                pass
        self._pairs.clear()


def _replace(temp: Path, target: Path, owned: list[Path] | None) -> None:
    """Rename ``temp`` to ``target``; an existing target (``owned``: what it consists of) is replaced, a folder
    by setting it aside, renaming, and removing only the entries its kind recognized."""
    if owned is None or not temp.is_dir():
        os.replace(temp, target)
        return
    aside = _temporary(target)
    os.rename(target, aside)
    try:
        os.rename(temp, target)
    except OSError:
        os.rename(aside, target)
        raise
    for entry in owned:
        (aside / entry.name).unlink(missing_ok=True)
    try:
        aside.rmdir()
    except OSError:  # something appeared in the old folder while it was replaced: kept (under a name that no
        kept = aside.with_name(f".tfrec-kept-{uuid.uuid4().hex[:8]}")  # cleanup of temporaries removes), said
        os.rename(aside, kept)
        warnings.warn(f"{target}: files that appeared in it while it was replaced are kept in {kept}", stacklevel=4)


def _rename_new(temp: Path, target: Path) -> None:
    """Rename ``temp`` to ``target``, which must not exist (atomically for a file: a hard link)."""
    if temp.is_dir():
        if os.path.lexists(target):
            raise FileExistsError(errno.EEXIST, "exists", str(target))
        os.rename(temp, target)
        return
    try:
        os.link(temp, target)  # atomic: fails if target exists
    except FileExistsError:
        raise
    except OSError as err:  # a file system without hard links
        if err.errno not in (errno.EPERM, errno.EOPNOTSUPP, errno.EXDEV, errno.EMLINK):
            raise
        if os.path.lexists(target):
            raise FileExistsError(errno.EEXIST, "exists", str(target)) from err
        os.replace(temp, target)
        return
    temp.unlink()


_MARK = "tfrec-"
_STALE = (
    re.compile(r"\.tfrec-(\d+)-[0-9a-f]{8}(?:\.[A-Za-z0-9]{1,16})?"),
    re.compile(r"\..+\.tmp-(\d+)-[0-9a-f]{8}"),  # tfrec 0.x's, named after the target
)
"""The names of temporaries: ``.tfrec-<pid>-<8 hex digits>[.<the target's extension>]``, and the older
``.<target>.tmp-<pid>-<8 hex digits>``."""


def _temp_suffix(target: Path) -> str:
    suffix = target.suffix
    return suffix if re.fullmatch(r"\.[A-Za-z0-9]{1,16}", suffix) else ""


def _temporary(target: Path) -> Path:
    """A new temporary name beside ``target``: short whatever the target's name (42 bytes at most)."""
    return target.parent / f".{_MARK}{os.getpid()}-{uuid.uuid4().hex[:8]}{_temp_suffix(target)}"


def _is_temporary(name: str) -> bool:
    return any(pattern.fullmatch(name) for pattern in _STALE)


def remove_stale_temporaries(folder: Path) -> list[Path]:
    """Remove the temporaries in ``folder`` whose process no longer exists (a run killed by SIGKILL, which
    cannot clean up), warning once about them; returns them. Temporaries of running processes are left."""
    removed: list[Path] = []
    try:
        entries = list(folder.iterdir())
    except OSError:
        return removed
    for entry in entries:
        match = next((m for m in (p.fullmatch(entry.name) for p in _STALE) if m is not None), None)
        if match is None or _alive(int(match.group(1))):
            continue
        try:
            if entry.is_dir() and not entry.is_symlink():
                shutil.rmtree(entry)
            else:
                entry.unlink()
        except OSError:
            continue
        removed.append(entry)
    if removed:
        shown = ", ".join(p.name for p in removed[:3]) + (f" and {len(removed) - 3} more" if len(removed) > 3 else "")
        warnings.warn(f"{folder}: removed {len(removed)} unfinished output{'s' if len(removed) > 1 else ''} of "
                      f"killed runs: {shown}", stacklevel=3)
    return removed


def _alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (OSError, OverflowError):  # another user's process: it exists
        return True
    return True
