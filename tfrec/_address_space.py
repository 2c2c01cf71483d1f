"""Running under an address-space limit (``ulimit -v``, ``RLIMIT_AS``, some containers and batch systems).

The limit counts address space reserved, not memory used: glibc reserves 64 MiB per thread for a malloc arena,
OpenBLAS and OpenMP a buffer per core, each thread its stack, and Rerun's Rust runtime starts a thread per core
— ``tfrec record --rrd`` reserved ~3.5 GB for ~230 MB resident. Under a limit that count meets, a thread that
cannot start is a ``RuntimeError`` in Python and an abort (SIGABRT) in Rust, and a failed allocation in Rust
aborts too. So, when a limit is set, :func:`economize` (the command line calls it first, before numpy and
rerun are imported) makes the process frugal: two malloc arenas, one BLAS/OpenMP thread, one Rust worker
thread; and :func:`check_rerun_address_space` refuses an ``.rrd`` output in one line below
:data:`RERUN_MIN_ADDRESS_SPACE`, the least a Rerun recording was measured to need, instead of letting Rerun
abort midway.
"""

from __future__ import annotations

import os
import resource

from tfrec.errors import WriteError

__all__ = [
    "FRUGAL_ENVIRONMENT",
    "RERUN_MIN_ADDRESS_SPACE",
    "address_space_limit",
    "check_rerun_address_space",
    "economize",
    "limit_phrase",
]

FRUGAL_ENVIRONMENT = {
    "OPENBLAS_NUM_THREADS": "1",  # read when numpy loads OpenBLAS
    "OMP_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
    "RAYON_NUM_THREADS": "1",  # Rerun's Rust: rayon's pool, tokio's workers
    "TOKIO_WORKER_THREADS": "1",
    "MIMALLOC_ARENA_RESERVE": "65536",  # KiB: Rerun's mimalloc reserves 1 GiB at once otherwise
    "MALLOC_ARENA_MAX": "2",  # for child processes; this one is told with mallopt
}
"""Set (unless already set) when the address space is limited."""

RERUN_MIN_ADDRESS_SPACE = 1024 << 20
"""The least address space tfrec writes an ``.rrd`` in. Measured with :data:`FRUGAL_ENVIRONMENT` (``tfrec record
--duration 1``, limits in steps of 50-100 MiB): robots/marm.xacro worked from 600 MiB, Franka's panda from 768 MiB,
a robot with an STL and a COLLADA mesh from 850 MiB (at 800 MiB a thread could not start: one error line); below,
Rerun's Rust aborted or hung. Without it, each failed at limits up to 2 GiB (Rerun's mimalloc reserved 1 GiB at
once). 1 GiB leaves a margin for larger robots and meshes."""

_M_ARENA_MAX = -8  # glibc's mallopt parameter


def address_space_limit() -> int | None:
    """The process's address-space limit (soft ``RLIMIT_AS``) in bytes; None without one."""
    soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    return None if soft == resource.RLIM_INFINITY else int(soft)


def limit_phrase() -> str:
    """``ulimit -v is 1,024 MiB`` (``""`` without a limit): for error lines about memory."""
    limit = address_space_limit()
    return "" if limit is None else f"ulimit -v is {limit >> 20:,} MiB"


def economize() -> None:
    """Make the process frugal with address space when it is limited (see the module's docstring); nothing
    without a limit. Variables the user set are kept."""
    if address_space_limit() is None:
        return
    for name, value in FRUGAL_ENVIRONMENT.items():
        os.environ.setdefault(name, value)
    try:
        import ctypes

        libc = ctypes.CDLL(None)
        mallopt = libc.mallopt
    except (OSError, AttributeError):  # not glibc: its arenas are not the question
        return
    mallopt(_M_ARENA_MAX, int(os.environ["MALLOC_ARENA_MAX"]) if os.environ["MALLOC_ARENA_MAX"].isdigit() else 2)


def check_rerun_address_space(target: str) -> None:
    """Refuse an ``.rrd`` output (before any output is written) when the address space is limited below
    :data:`RERUN_MIN_ADDRESS_SPACE`.

    Raises:
        WriteError: naming ``target``, the address space needed and the limit.
    """
    limit = address_space_limit()
    if limit is not None and limit < RERUN_MIN_ADDRESS_SPACE:
        raise WriteError(f"{target}: a Rerun recording needs an address space of at least "
                         f"{RERUN_MIN_ADDRESS_SPACE >> 20:,} MiB; {limit_phrase()} (raise it, or write no .rrd)")
