"""Atomic outputs: every file (or folder) of one command appears complete, or not at all.

Each output is written to a temporary name beside its target (same folder, so the rename is atomic;
:func:`tfrec._outputs.temporary_name`) and all are renamed together by :meth:`AtomicOutputs.commit`; after an
error, Ctrl-C or SIGTERM the temporaries are deleted and older files of those names are untouched; errors name the
targets, never the temporaries. An existing target is replaced only when its kind recognizes it, checked again at
that moment (:func:`tfrec._outputs.check_existing`), and a folder by removing only the entries its kind
recognized. :func:`tfrec._outputs.check_outputs` is the check of a command's outputs before anything is read;
temporaries of killed runs are removed by the next run into their folder (:func:`remove_stale_temporaries`).
"""

from __future__ import annotations

import errno
import os
import shutil
import uuid
import warnings
from pathlib import Path
from types import TracebackType
from typing import final

from tfrec._outputs import REPLACES, NotOurs, OutputKind, check_existing, refusal, stale_temporaries, temporary_name
from tfrec.errors import RecordingError, TfrecError, TfrecWarning, WriteError

__all__ = ["AtomicOutputs", "remove_stale_temporaries"]


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
        remove_stale_temporaries(target.parent, kind)
        temp = temporary_name(target)
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
                check_existing(target, kind, force=True)
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
    aside = temporary_name(target)
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
        warnings.warn(f"{target}: files that appeared in it while it was replaced are kept in {kept}", TfrecWarning, stacklevel=4)


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


def remove_stale_temporaries(folder: Path, kind: OutputKind) -> list[Path]:
    """Remove the temporaries of ``kind`` in ``folder`` that killed runs left (SIGKILL cannot clean up) — only
    those :func:`tfrec._outputs.stale_temporaries` is sure of —, warning once about them; returns them."""
    removed: list[Path] = []
    for entry in stale_temporaries(folder, kind, alive=_alive):
        try:
            if kind.folder:
                shutil.rmtree(entry)
            else:
                entry.unlink()
        except OSError:
            continue
        removed.append(entry)
    if removed:
        shown = ", ".join(p.name for p in removed[:3]) + (f" and {len(removed) - 3} more" if len(removed) > 3 else "")
        warnings.warn(f"{folder}: removed {len(removed)} unfinished output{'s' if len(removed) > 1 else ''} of "
                      f"killed runs: {shown}", TfrecWarning, stacklevel=3)
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
