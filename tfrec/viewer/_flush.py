"""Waiting for Rerun's writer without hanging: a flush that Ctrl-C and SIGTERM interrupt and that fails
when the writer has died.

``RecordingStream.flush()`` blocks in native code until Rerun's writer thread has written everything.
When that thread dies (the disk is full), it waits forever, and since Python runs signal handlers only
between bytecodes, SIGTERM and Ctrl-C are ignored too (only SIGKILL ended a ``replay --save`` onto a full
disk). So the wait is cut into short flushes; between them Python handles signals, and a writer that
makes no progress while its disk is full, or for :data:`STALL_S`, is reported as an error.
"""

from __future__ import annotations

import os
import shutil
import time
from pathlib import Path
from typing import Any

from tfrec.errors import WriteError

__all__ = ["STALL_S", "STUCK", "disconnect", "flush"]

STUCK = False
"""True once a writer could not be closed (a dead file writer): Rerun's exit handler would then wait for
it forever, so the command line ends the process without exit handlers (:func:`tfrec.cli.main_exit`)."""

STEP_S = 0.25
"""How long one flush waits before Python gets a chance to handle signals."""

STALL_S = 120.0
"""A writer that writes nothing for this long is taken for dead."""

_FULL_BYTES = 1 << 20
"""Free space below which a stalled file writer is taken to have hit a full disk."""


def flush(recording: Any, *, file: Path | None, target: str) -> None:
    """Flush ``recording`` (a ``rerun.RecordingStream``) to its file or viewer.

    Args:
        recording: the stream.
        file: the file it writes (None for a viewer), watched for progress.
        target: how messages name the output.

    Raises:
        WriteError: the writer failed (disk full, file too large, viewer gone) or stopped making progress.
    """
    verb = "cannot write" if file is not None else "cannot send to the recording"
    size = _size(file)
    stalled_since = time.monotonic()
    while True:
        try:
            recording.flush(timeout_sec=STEP_S)
            return
        except RuntimeError as err:
            if "timeout" not in str(err).lower() and "timed out" not in str(err).lower():
                raise WriteError(f"{target}: {verb}: {err}") from err
        now_size = _size(file)  # a timeout: Python handles pending signals here, then the writer is checked
        if now_size != size:
            size, stalled_since = now_size, time.monotonic()
            continue
        if file is not None and _free(file) < _FULL_BYTES:
            raise WriteError(f"{target}: {verb}: {os.strerror(28)}")  # ENOSPC: No space left on device
        if time.monotonic() - stalled_since > STALL_S:
            raise WriteError(f"{target}: {verb}: Rerun's writer made no progress for {STALL_S:g} s")


def _size(file: Path | None) -> int:
    try:
        return file.stat().st_size if file is not None else 0
    except OSError:
        return 0


def _free(file: Path) -> int:
    try:
        return shutil.disk_usage(file.parent).free
    except OSError:
        return 1 << 62


def disconnect(recording: Any, *, wait_s: float = 5.0) -> None:
    """Close ``recording``'s sinks, waiting at most ``wait_s``: closing flushes, and a writer that died
    (disk full) would hold it forever. After that the closing is left to a daemon thread."""
    import threading

    global STUCK
    closer = threading.Thread(target=recording.disconnect, name="tfrec-rerun-close", daemon=True)
    closer.start()
    closer.join(wait_s)
    if closer.is_alive():
        STUCK = True
