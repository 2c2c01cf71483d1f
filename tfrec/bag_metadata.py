"""rosbag2 folders: ``metadata.yaml`` (version 9, MCAP storage) beside the ``.mcap``.

A rosbag2 bag is a folder ``<name>/`` holding ``metadata.yaml`` and ``<name>_0.mcap``. The
metadata is rosbag2's BagMetadata as yaml-cpp encodes it (Jazzy and later: metadata version 9,
offered QoS profiles as a YAML list with string enums); the same text is embedded in the MCAP
as its ``rosbag2`` metadata record (:class:`tfrec.mcap_io.McapSink`).
"""

from __future__ import annotations

import struct
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .errors import RecordingError

__all__ = [
    "BAG_VERSION",
    "ROS_DISTRO",
    "BagMetadata",
    "bag_info",
    "one_line",
    "qos_durability",
    "read_bag_metadata",
    "write_bag_metadata",
    "yaml_dump",
]

BAG_VERSION = 9
ROS_DISTRO = "jazzy"
"""metadata.yaml's ``ros_distro``: the layout (metadata version 9, string QoS enums) is Jazzy's."""


def write_bag_metadata(
    bag_dir: str | Path, mcap_path: str | Path, *, final_mcap_name: str | None = None
) -> Path:
    """Write ``metadata.yaml`` (rosbag2 version 9, storage ``mcap``) for an MCAP in ``bag_dir``.

    The counts, times and topics are read back from the MCAP's summary, so this works for any
    finished ROS 2 MCAP.

    Args:
        bag_dir: the bag folder (it exists).
        mcap_path: the MCAP file, normally ``<bag_dir>/<bag name>_0.mcap``.
        final_mcap_name: the name to list in the metadata when the file is renamed later
            (default: ``mcap_path``'s name).

    Returns:
        The path of the metadata file.

    Raises:
        RecordingError: the MCAP cannot be read or has no summary.
    """
    from mcap.exceptions import McapError
    from mcap.reader import make_reader

    mcap_path = Path(mcap_path)
    try:
        with open(mcap_path, "rb") as stream:
            summary = make_reader(stream).get_summary()
    except (OSError, McapError, ValueError, struct.error) as err:
        raise RecordingError(f"{mcap_path}: cannot read MCAP summary: {err}") from None
    if summary is None or summary.statistics is None:
        raise RecordingError(f"{mcap_path}: MCAP has no summary statistics")
    stats = summary.statistics
    topics = []
    for channel_id, channel in sorted(summary.channels.items()):
        schema = summary.schemas.get(channel.schema_id)
        topics.append((
            channel.topic, schema.name if schema else "", channel.message_encoding,
            channel.metadata.get("offered_qos_profiles", ""), channel.metadata.get("topic_type_hash", ""),
            stats.channel_message_counts.get(channel_id, 0),
        ))
    info = bag_info(
        topics, message_count=stats.message_count, start_ns=stats.message_start_time,
        end_ns=stats.message_end_time, file_name=final_mcap_name or mcap_path.name,
    )
    path = Path(bag_dir) / "metadata.yaml"
    path.write_text(yaml_dump({"rosbag2_bagfile_information": info}), encoding="utf-8")
    return path


def bag_info(
    topics: Sequence[tuple[str, str, str, str, str, int]],
    *,
    message_count: int,
    start_ns: int,
    end_ns: int,
    file_name: str,
) -> dict[str, Any]:
    """rosbag2's BagMetadata (version 9) as yaml-cpp would encode it, keys in rosbag2's order.

    Args:
        topics: (name, type, serialization format, offered QoS YAML, type hash, message count).
    """
    duration = max(0, end_ns - start_ns) if message_count else 0
    start = start_ns if message_count else 0
    return {
        "version": BAG_VERSION,
        "storage_identifier": "mcap",
        "duration": {"nanoseconds": duration},
        "starting_time": {"nanoseconds_since_epoch": start},
        "message_count": message_count,
        "topics_with_message_count": [
            {
                "topic_metadata": {
                    "name": name,
                    "type": msgtype,
                    "serialization_format": serialization,
                    "offered_qos_profiles": _yaml_load(qos) or [],
                    "type_description_hash": type_hash,
                },
                "message_count": count,
            }
            for name, msgtype, serialization, qos, type_hash, count in topics
        ],
        "compression_format": "",
        "compression_mode": "",
        "relative_file_paths": [file_name] if file_name else [],
        "files": [{
            "path": file_name,
            "starting_time": {"nanoseconds_since_epoch": start},
            "duration": {"nanoseconds": duration},
            "message_count": message_count,
        }] if file_name else [],
        "custom_data": None,
        "ros_distro": ROS_DISTRO,
    }


def _yaml_load(text: str) -> Any:
    import yaml

    try:
        return yaml.safe_load(text) if text else None
    except yaml.YAMLError:
        return None


def yaml_dump(data: Any) -> str:
    """Block-style YAML with indented sequences, ``~`` and ``""``, as yaml-cpp (rosbag2) writes it."""
    import yaml

    def indent_sequences(self: Any, flow: bool = False, indentless: bool = False) -> None:
        yaml.SafeDumper.increase_indent(self, flow, False)

    dumper: Any = type("_RosbagDumper", (yaml.SafeDumper,), {"increase_indent": indent_sequences})
    dumper.add_representer(type(None), lambda d, _: d.represent_scalar("tag:yaml.org,2002:null", "~"))
    dumper.add_representer(str, lambda d, v: d.represent_scalar("tag:yaml.org,2002:str", v, style='"' if v == "" else None))
    return str(yaml.dump(data, Dumper=dumper, sort_keys=False, default_flow_style=False, width=1 << 16))


@dataclass(frozen=True, slots=True)
class BagMetadata:
    """What tfrec needs of a rosbag2 folder's ``metadata.yaml``.

    Attributes:
        storage: the storage plugin, ``mcap`` or ``sqlite3``.
        files: the bag's files, in order.
        compression: ``compression_format`` (``zstd`` for a compressed bag), or ``""``.
    """

    storage: str
    files: tuple[Path, ...]
    compression: str


def read_bag_metadata(folder: Path) -> BagMetadata:
    """Read a rosbag2 folder's ``metadata.yaml``.

    Raises:
        RecordingError: no or malformed metadata.yaml (one line naming the file, and the line
            of a YAML syntax error), or a listed file that is missing.
    """
    import yaml

    meta = folder / "metadata.yaml"
    if not meta.is_file():
        raise RecordingError(f"{folder}: a folder without metadata.yaml is not a rosbag2 bag")
    try:
        document = yaml.safe_load(meta.read_text(encoding="utf-8"))
    except OSError as err:
        raise RecordingError(f"{meta}: cannot read: {err.strerror or err}") from None
    except UnicodeDecodeError as err:
        raise RecordingError(f"{meta}: not UTF-8 text (byte {err.start:,})") from None
    except yaml.MarkedYAMLError as err:
        line = f":{err.problem_mark.line + 1}" if err.problem_mark is not None else ""
        raise RecordingError(f"{meta}{line}: not valid YAML: {one_line(err.problem or str(err))}") from None
    except yaml.YAMLError as err:
        raise RecordingError(f"{meta}: not valid YAML: {one_line(str(err))}") from None
    info = document.get("rosbag2_bagfile_information") if isinstance(document, dict) else None
    if not isinstance(info, dict):
        raise RecordingError(f"{meta}: not a rosbag2 metadata file (no rosbag2_bagfile_information mapping)")
    names = info.get("relative_file_paths")
    if not isinstance(names, list) or not names:
        raise RecordingError(f"{meta}: rosbag2_bagfile_information lists no relative_file_paths")
    files = tuple(folder / Path(str(name)).name for name in names)
    for file in files:
        if not file.is_file():
            raise RecordingError(f"{folder}: metadata.yaml lists {file.name}, which is missing")
    return BagMetadata(str(info.get("storage_identifier") or ""), files, str(info.get("compression_format") or ""))


def one_line(text: str) -> str:
    """A library's error message on one line: runs of whitespace (newlines too) become one space."""
    return " ".join(text.split())


_DURABILITY = {0: "system_default", 1: "transient_local", 2: "volatile", 3: "unknown", 4: "best_available"}


def qos_durability(offered_qos_profiles: str) -> str | None:
    """The durability of the first offered QoS profile, from rosbag2's YAML text (the
    ``offered_qos_profiles`` of MCAP channel metadata, of sqlite3's topics table); None when
    there is none. Numbers (Humble and older) are named as the strings Jazzy writes."""
    profiles = _yaml_load(offered_qos_profiles)
    try:
        value = profiles[0]["durability"]
    except (TypeError, KeyError, IndexError):
        return None
    return _DURABILITY.get(value, "unknown") if isinstance(value, int) else str(value)
