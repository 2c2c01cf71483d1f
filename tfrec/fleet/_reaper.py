"""The reaper of a driver's descendants (see :mod:`tfrec.fleet.lifetime`), run as a script:
``python -I -S _reaper.py DRIVER_PID POLL_S TOKEN`` with stdin a pipe from the driver.

It first notes the driver's descendants that already run (they are not its business: a process
pool of the caller's, say), writes ``ready`` on stdout, then, while the pipe is open, lists every
POLL_S seconds the processes descended from the driver since (a local Ray cluster: GCS, raylet, its
agents and workers). When the pipe closes — the driver died, or
finished and shut its cluster down — it kills (SIGKILL) each process it saw that still runs and its
descendants: the ones that would otherwise wait a minute for the dead GCS. A process is known by
its pid and start time, so that a pid used again by another process is never killed. Processes too
young to have been seen, whose parent died first (a Ray worker starting as its raylet is killed),
are found by the variable ``TFREC_REAPER=TOKEN`` in their environment, which the driver set while
it started the cluster (Ray's processes pass their environment on; the agents, whose environment
Ray's process titles overwrite, are old enough to have been seen).

Linux only (``/proc``); elsewhere it only waits for the pipe to close. Standard library only: it
runs with ``-I -S``, without tfrec or the environment's packages.
"""

from __future__ import annotations

import os
import select
import signal
import sys

Known = dict[int, str]
"""pid → start time (field 22 of /proc/PID/stat)."""


def _table() -> dict[int, tuple[int, str]]:
    """Every live process: pid → (parent pid, start time)."""
    out: dict[int, tuple[int, str]] = {}
    try:
        names = os.listdir("/proc")
    except OSError:
        return out
    for name in names:
        if not name.isdigit():
            continue
        try:
            with open(f"/proc/{name}/stat", "rb") as stat:
                text = stat.read().decode("ascii", "replace")
        except OSError:
            continue
        fields = text[text.rfind(")") + 2 :].split()
        if len(fields) > 19 and fields[0] != "Z":
            out[int(name)] = (int(fields[1]), fields[19])
    return out


def _descendants(roots: set[int], table: dict[int, tuple[int, str]], skip: Known | None = None) -> Known:
    """The processes of ``table`` descended from ``roots`` (not the roots themselves), leaving out the
    processes of ``skip`` (same pid and start time) and their descendants."""
    children: dict[int, list[int]] = {}
    for pid, (ppid, _) in table.items():
        children.setdefault(ppid, []).append(pid)
    skip = skip or {}
    found: Known = {}
    todo = list(roots)
    while todo:
        for child in children.get(todo.pop(), ()):
            if skip.get(child) == table[child][1]:
                continue
            if child not in found and child not in roots:
                found[child] = table[child][1]
                todo.append(child)
    return found


def _marked(table: dict[int, tuple[int, str]], token: str) -> set[int]:
    """The processes whose environment holds ``TFREC_REAPER=token``."""
    mark = f"TFREC_REAPER={token}".encode()
    found = set()
    for pid in table:
        try:
            with open(f"/proc/{pid}/environ", "rb") as environ:
                if mark in environ.read().split(b"\0"):
                    found.add(pid)
        except OSError:  # gone, or another user's
            continue
    return found


def _reap(known: Known, token: str) -> None:
    table = _table()
    alive = {pid for pid, start in known.items() if pid in table and table[pid][1] == start} | _marked(table, token)
    targets = alive | set(_descendants(alive, table))
    targets.discard(os.getpid())
    for pid in targets:
        try:
            os.kill(pid, signal.SIGKILL)
        except OSError:
            pass


def main(argv: list[str]) -> int:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the driver's: it shuts its cluster down itself
    driver, poll_s, token = int(argv[1]), float(argv[2]), argv[3]
    before = _descendants({driver}, _table())
    os.write(1, b"ready\n")
    known: Known = {}
    while True:
        seen = _descendants({driver}, _table(), skip=before)
        seen.pop(os.getpid(), None)
        known.update(seen)
        ready, _, _ = select.select([0], [], [], poll_s)
        if ready and not os.read(0, 4096):
            break
    _reap(known, token)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
