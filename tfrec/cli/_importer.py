"""``rerun-importer-tfrec``: the Rerun importer (:mod:`tfrec.replay.importer`), run by ``rerun FILE``.

Exit codes: 0 with an RRD stream on standard output, 66 for a file tfrec does not handle, 2 (one ``tfrec: error:``
line on stderr, which Rerun shows) for one it handles but cannot read.
"""

from __future__ import annotations

import argparse
import os
import sys
import warnings
from collections.abc import Sequence

from tfrec.cli._common import show
from tfrec.errors import TfrecError, printable

__all__ = ["main", "main_exit"]


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="rerun-importer-tfrec", description=(
        "The Rerun importer of tfrec: `rerun robot.xacro`, `rerun x.bag`, `rerun bag/x.db3` show them. Writes an "
        "RRD stream to stdout, or exits 66 for files tfrec does not handle. Rerun runs it; the options are Rerun's."))
    parser.add_argument("filepath")
    parser.add_argument("--application-id")
    parser.add_argument("--opened-application-id")
    parser.add_argument("--recording-id")
    parser.add_argument("--opened-recording-id")
    parser.add_argument("--entity-path-prefix")
    parser.add_argument("--static", action="store_true")
    for flag in ("--time_sequence", "--time_duration_nanos", "--time_timestamp_nanos", "--time", "--sequence"):
        parser.add_argument(flag, nargs="*", default=[])
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the importer; returns the exit code."""
    from tfrec.replay.importer import INCOMPATIBLE_EXIT_CODE, import_file, importable

    os.environ.setdefault("RUST_LOG", "off")
    ns, _ = _parser().parse_known_args(argv)  # options of later Rerun releases are ignored
    if importable(ns.filepath) is None:
        return INCOMPATIBLE_EXIT_CODE
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # stdout is the RRD stream; Rerun has nowhere to show warnings
        try:
            # Rerun's recording id (its files of one opening go together); tfrec's application id, so that the
            # .rrd a viewer saves reads back with tfrec (replay, diff, check) like the ones tfrec writes
            import_file(ns.filepath, recording_id=ns.recording_id, application_id=None)
        except TfrecError as err:
            show(f"tfrec: error: {printable(str(err))}", file=sys.stderr)
            return 2
    return 0


def main_exit() -> None:
    """Console-script entry point: ``sys.exit(main())``."""
    sys.exit(main())
