"""Decoding an ``.rrd`` file's chunks in a child process (run as a script: ``python _read_child.py FILE``).

Rerun's reader is Rust code built with ``panic = "abort"``: a damaged file (an Arrow buffer whose length points
past its message) aborts the whole process instead of raising. :func:`tfrec.formats.rrd.reader.read_rrd` runs
this script in a child process and takes what it writes to stdout: an 8-byte little-endian length and a JSON
list of the application ids of the file's recordings, then for each chunk an 8-byte little-endian length and one
Arrow IPC stream holding the chunk's record batch, its entity path in the schema metadata under
``tfrec:entity_path``. pyarrow validates those streams when reading them back, so nothing reaches the parent that
could crash it. Rerun's own errors go to stderr as one line, with exit code :data:`REFUSED`.

The script imports rerun and pyarrow only (not tfrec), so it runs whatever ``sys.path`` the parent had.
"""

from __future__ import annotations

import json
import struct
import sys
import warnings

REFUSED = 3
"""Exit code: Rerun refused the file with an exception (its message is on stderr)."""

ENTITY_PATH = b"tfrec:entity_path"


def main(path: str) -> int:
    import pyarrow as pa
    from rerun.chunk import RrdReader

    out = sys.stdout.buffer
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            reader = RrdReader(path)
            applications = json.dumps(sorted({entry.application_id for entry in reader.recordings()})).encode()
            out.write(struct.pack("<Q", len(applications)))
            out.write(applications)
            for chunk in reader.stream():
                batch = chunk.to_record_batch()
                metadata = {**(batch.schema.metadata or {}), ENTITY_PATH: str(chunk.entity_path).encode()}
                batch = batch.replace_schema_metadata(metadata)
                sink = pa.BufferOutputStream()
                with pa.ipc.new_stream(sink, batch.schema) as writer:
                    writer.write_batch(batch)
                data = sink.getvalue()
                out.write(struct.pack("<Q", data.size))
                out.write(data)
    except (RuntimeError, ValueError, OSError) as err:
        print(" ".join(str(err).split()), file=sys.stderr)
        return REFUSED
    out.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
