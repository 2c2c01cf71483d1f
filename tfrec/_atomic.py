"""Atomic outputs: every file (or folder) of one command appears complete, or not at all.

Each output is written to a temporary name beside its target (same folder, so the rename is atomic) and
all are renamed together by :meth:`AtomicOutputs.commit`; after an error or Ctrl-C the temporaries are
deleted and older files of those names are untouched. ``tfrec record`` (:func:`tfrec.recorder.record`)
and ``tfrec replay --save`` (:func:`tfrec.replay.play.replay_to_rerun`) write through it, before any sink
sees a path; :func:`check_target` is their common check of an output's name before anything is read.
"""

from __future__ import annotations

import errno
import os
import re
import shutil
import uuid
import warnings
from pathlib import Path
from types import TracebackType
from typing import final

from tfrec.errors import RecordingError, WriteError

__all__ = ["AtomicOutputs", "check_target"]


def check_target(target: Path, *, suffix: str | None, what: str, force: bool, folder: bool = False) -> None:
    """Check an output's name before anything is written.

    Args:
        target: the output.
        suffix: the extension its name must end in (None: any).
        what: the kind of output, for messages (``MCAP``, ``Rerun``).
        force: an existing output of the same kind (file or folder) may be replaced.
        folder: the output is a folder (a rosbag2 bag), not a file.

    Raises:
        RecordingError: a wrong extension, an existing output without ``force``, or a file where a
            folder is written (or the other way round).
    """
    if suffix is not None and target.suffix != suffix:
        raise WriteError(f"{target}: the {what} output's name must end in {suffix}")
    if not target.exists():
        return
    if target.is_dir() != folder:
        raise WriteError(f"{target}: exists and is a {'folder' if target.is_dir() else 'file'}")
    if not force:
        raise WriteError(f"{target}: already exists (use `force` to overwrite)")


@final
class AtomicOutputs:
    """Temporary outputs beside their targets, renamed together by :meth:`commit`.

    Use it as a context manager and call :meth:`commit` last inside the block; leaving the block
    otherwise deletes the temporaries. Leaving it by an ``OSError`` or a ``RecordingError`` raises a
    ``RecordingError`` that names the targets, never the temporary names::

        with AtomicOutputs() as outputs:
            write(outputs.path(target))
            outputs.commit()
    """

    def __init__(self, *, replace: bool = True) -> None:
        """``replace``: targets that exist at commit time are replaced (``--force``); without it a
        target that appeared meanwhile (another process writing the same name) is an error."""
        self._pairs: list[tuple[Path, Path]] = []
        self._replace = replace

    def __enter__(self) -> AtomicOutputs:
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 traceback: TracebackType | None) -> None:
        if error is None:
            self.abort()  # left without commit(): nothing is kept
            return
        message = None
        if isinstance(error, OSError):
            message = f"{self.target_of(error.filename)}: cannot write: {error.strerror or error}"
        elif isinstance(error, RecordingError):  # a sink's message names its temporary file
            message = self.with_targets(str(error))
        self.abort()
        if message is not None:
            raise WriteError(message) from error

    def path(self, target: Path, *, directory: bool = False) -> Path:
        """A temporary name for ``target`` in its folder (created, with its parents); with
        ``directory`` the temporary folder is created too. Temporaries that killed runs (SIGKILL, a
        power cut) left in that folder are removed first, with a warning."""
        self._pairs.append((target, target))  # until the temporary exists, errors name the target
        target.parent.mkdir(parents=True, exist_ok=True)
        self._pairs.pop()
        remove_stale_temporaries(target.parent)
        temp = target.parent / f".{target.name}{_TEMP_MARK}{os.getpid()}-{uuid.uuid4().hex[:8]}"
        if directory:
            temp.mkdir()
        self._pairs.append((temp, target))
        return temp

    def target_of(self, filename: object) -> str:
        """The output a (temporary) file name stands for, for messages."""
        if filename is None:  # an error of a library that does not say which file (the outputs, then)
            return ", ".join(dict.fromkeys(str(target) for _, target in self._pairs)) or "output"
        name = Path(os.fsdecode(filename))  # type: ignore[arg-type]
        for temp, target in self._pairs:
            if name == temp or temp in name.parents:
                return str(target)
        return str(name)

    def with_targets(self, message: str) -> str:
        """``message`` with every temporary path replaced by its target's."""
        for temp, target in self._pairs:
            message = message.replace(str(temp), str(target))
        return message

    def commit(self) -> None:
        """Rename every temporary to its target.

        Raises:
            RecordingError: without ``replace``, a target exists now (the outputs committed by
                this call are removed again, the temporaries deleted).
        """
        done: list[Path] = []
        try:
            for temp, target in self._pairs:
                self._rename(temp, target)
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

    def _rename(self, temp: Path, target: Path) -> None:
        if self._replace:
            if target.is_dir() and temp.is_dir():
                shutil.rmtree(target)
            os.replace(temp, target)
        elif temp.is_dir():
            if target.exists() or target.is_symlink():
                raise FileExistsError(errno.EEXIST, "exists", str(target))
            os.rename(temp, target)
        else:
            try:
                os.link(temp, target)  # atomic: fails if target exists
            except FileExistsError:
                raise
            except OSError as err:  # a file system without hard links
                if err.errno not in (errno.EPERM, errno.EOPNOTSUPP, errno.EXDEV, errno.EMLINK):
                    raise
                if target.exists():
                    raise FileExistsError(errno.EEXIST, "exists", str(target)) from err
                os.replace(temp, target)
                return
            temp.unlink()

    def abort(self) -> None:
        """Delete the temporaries not yet renamed (one that could not be created, in a read-only folder say,
        is no error)."""
        for temp, _ in self._pairs:
            if temp.is_dir():
                shutil.rmtree(temp, ignore_errors=True)
            else:
                try:
                    temp.unlink(missing_ok=True)
                except OSError:
                    pass
        self._pairs.clear()


_TEMP_MARK = ".tmp-"
_STALE = re.compile(r"\..+\.tmp-(\d+)-[0-9a-f]{8}")
"""The name of a temporary: ``.<target>.tmp-<pid>-<8 hex digits>``."""


def remove_stale_temporaries(folder: Path) -> list[Path]:
    """Remove the temporaries in ``folder`` whose process no longer exists (a run killed by SIGKILL, which
    cannot clean up), warning once about them; returns them. Temporaries of running processes are left."""
    removed: list[Path] = []
    try:
        entries = list(folder.iterdir())
    except OSError:
        return removed
    for entry in entries:
        match = _STALE.fullmatch(entry.name)
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
    except OSError:  # another user's process: it exists
        return True
    return True
