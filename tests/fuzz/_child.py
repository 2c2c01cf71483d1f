"""One fuzz run in its own process (``make fuzz``): tfrec's command line under ``RLIMIT_AS``.

``python -m tests.fuzz._child ARGS...`` is ``tfrec ARGS...`` with the address space limited to
``TFREC_FUZZ_RLIMIT_AS`` bytes (default 1 GiB): a run that needs more fails with MemoryError (a
traceback, which the harness reports) instead of taking the machine down; and, when ``TFREC_FUZZ_RLIMIT_CPU``
is set, its CPU time to that many seconds (``RLIMIT_CPU``: past it the kernel ends the run with SIGXCPU — a hang
guard that counts the run's own work, not the wall clock of a busy machine).
"""

from __future__ import annotations

import os
import resource
import sys


def run() -> None:
    limit = int(os.environ.get("TFREC_FUZZ_RLIMIT_AS", str(1 << 30)))
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    cpu = os.environ.get("TFREC_FUZZ_RLIMIT_CPU")
    if cpu:
        resource.setrlimit(resource.RLIMIT_CPU, (int(cpu), int(cpu) + 5))
    from tfrec.cli import main_exit

    sys.argv = ["tfrec", *sys.argv[1:]]
    main_exit()


if __name__ == "__main__":
    run()
