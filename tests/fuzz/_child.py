"""One fuzz run in its own process (``make fuzz``): tfrec's command line under ``RLIMIT_AS``.

``python -m tests.fuzz._child ARGS...`` is ``tfrec ARGS...`` with the address space limited to
``TFREC_FUZZ_RLIMIT_AS`` bytes (default 1 GiB): a run that needs more fails with MemoryError (a
traceback, which the harness reports) instead of taking the machine down; and its CPU time to
``TFREC_FUZZ_RLIMIT_CPU`` seconds (default 30): a run that spins longer is ended by SIGXCPU.
"""

from __future__ import annotations

import math
import os
import resource
import sys


def run() -> None:
    limit = int(os.environ.get("TFREC_FUZZ_RLIMIT_AS", str(1 << 30)))
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    cpu = math.ceil(float(os.environ.get("TFREC_FUZZ_RLIMIT_CPU", "30")))
    resource.setrlimit(resource.RLIMIT_CPU, (cpu, cpu + 5))
    from tfrec.cli import main_exit

    sys.argv = ["tfrec", *sys.argv[1:]]
    main_exit()


if __name__ == "__main__":
    run()
