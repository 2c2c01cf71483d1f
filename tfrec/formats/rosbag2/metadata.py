"""rosbag2 folders: ``metadata.yaml`` (version 9, MCAP storage) beside the ``.mcap``.

A rosbag2 bag is a folder ``<name>/`` holding ``metadata.yaml`` and ``<name>_0.mcap``. The
metadata is rosbag2's BagMetadata as yaml-cpp encodes it (Jazzy and later: metadata version 9,
offered QoS profiles as a YAML list with string enums); the same text, less the file list, is embedded
in the MCAP as its ``rosbag2`` metadata record (:class:`tfrec.formats.mcap.sink.McapSink`, which
builds it with :func:`bag_info` and keeps it for :func:`write_bag_metadata`). Only ``metadata.yaml``
names the bag's files: an MCAP's bytes do not depend on the name it is written under (the same
recording as ``out.mcap`` and as ``bag/bag_0.mcap`` is the same bytes). The offered QoS profiles are defined
once here, as data: :data:`QOS_LATCHED`, :data:`QOS_VOLATILE`.
"""

from __future__ import annotations

import copy
import re
import stat
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

from tfrec.errors import ReadError, TfrecWarning

__all__ = [
    "BAG_VERSION",
    "QOS_LATCHED",
    "QOS_VOLATILE",
    "ROS_DISTRO",
    "BagMetadata",
    "bag_info",
    "bag_metadata_yaml",
    "bag_storage_name",
    "bag_without_metadata",
    "offered_qos_profiles",
    "one_line",
    "qos_durability",
    "qos_yaml",
    "read_bag_metadata",
    "write_bag_metadata",
]

METADATA_MAX_BYTES = 16 << 20
"""The largest metadata.yaml read (rosbag2 writes a few kB; one with thousands of topics, a few MB)."""

MAX_STORAGE_FILES = 100_000
"""Storage files a rosbag2 bag may list (distinct ones): a bag split every minute for two months has 90,000."""

BAG_VERSION = 9
ROS_DISTRO = "jazzy"
"""metadata.yaml's ``ros_distro``: the layout (metadata version 9, string QoS enums) is Jazzy's."""


_INFINITE = {"sec": 9223372036, "nsec": 854775807}
"""An unset QoS duration as rosbag2 writes it: RMW_DURATION_INFINITE."""


def _offered_qos(durability: str) -> dict[str, Any]:
    # What rosbag2 (metadata version 9, Jazzy and later) serializes of a publisher it discovered:
    # the history depth is not discoverable (unknown, 0) and unset durations read as infinite.
    return {
        "history": "unknown",
        "depth": 0,
        "reliability": "reliable",
        "durability": durability,
        "deadline": _INFINITE,
        "lifespan": _INFINITE,
        "liveliness": "automatic",
        "liveliness_lease_duration": _INFINITE,
        "avoid_ros_namespace_conventions": False,
    }


QOS_LATCHED = _offered_qos("transient_local")
"""The QoS robot_state_publisher offers on /robot_description and /tf_static: reliable, latched. Read only."""
QOS_VOLATILE = _offered_qos("volatile")
"""The QoS joint_state_publisher and robot_state_publisher offer on /joint_states and /tf. Read only."""


def _offered_qos_text(durability: str) -> str:
    """:func:`qos_yaml` of ``[_offered_qos(durability)]``, written out (tests compare with PyYAML's): the QoS of
    tfrec's own recordings is known without loading PyYAML, which took longer to import than ``tfrec info`` of a
    small MCAP spends reading it."""
    infinite = "".join(f"\n    {key}: {value}" for key, value in _INFINITE.items())
    return (f"- history: unknown\n  depth: 0\n  reliability: reliable\n  durability: {durability}\n"
            f"  deadline:{infinite}\n  lifespan:{infinite}\n  liveliness: automatic\n"
            f"  liveliness_lease_duration:{infinite}\n  avoid_ros_namespace_conventions: false")


_KNOWN_QOS = {_offered_qos_text(durability): [profile]
              for durability, profile in (("transient_local", QOS_LATCHED), ("volatile", QOS_VOLATILE))}
"""The ``offered_qos_profiles`` texts tfrec writes → their profile lists (read only)."""


def qos_yaml(profiles: Sequence[Mapping[str, Any]]) -> str:
    """Offered QoS profiles as the ``offered_qos_profiles`` text of MCAP channel metadata: a YAML
    list, no trailing newline (yaml-cpp's ``Dump``)."""
    key = repr(profiles)
    text = _QOS_TEXTS.get(key)
    if text is None:  # a few distinct lists make up the QoS of thousands of channels: each dumped once
        from tfrec._yaml import yaml_dump

        text = yaml_dump(list(profiles)).rstrip("\n")
        if len(_QOS_TEXTS) < 256:
            _QOS_TEXTS[key] = text
    return text


_QOS_TEXTS: dict[str, str] = {repr(profiles): text for text, profiles in _KNOWN_QOS.items()}


def bag_storage_name(folder_name: str) -> str:
    """The MCAP file tfrec writes in a rosbag2 folder: ``<name>_0.mcap``, named after it as ``ros2 bag record``
    names it (so a folder's name has at most 248 bytes: :data:`tfrec.formats.kinds.ROSBAG2` checks it)."""
    return f"{folder_name}_0.mcap"


def write_bag_metadata(bag_dir: str | Path, info: Mapping[str, Any], *, file_name: str) -> Path:
    """Write a bag folder's ``metadata.yaml``, naming its one storage file.

    Args:
        bag_dir: the bag folder (it exists).
        info: the bag's BagMetadata, from :func:`bag_info` (:attr:`tfrec.formats.mcap.sink.McapSink.bag_info`
            of its MCAP).
        file_name: the storage file in the folder (rosbag2's ``<folder>_0.mcap``), listed in
            ``relative_file_paths`` and ``files``.

    Returns:
        The path of the metadata file.
    """
    listed = dict(info)
    listed["relative_file_paths"] = [file_name]
    listed["files"] = [{
        "path": file_name,
        "starting_time": copy.deepcopy(info["starting_time"]),
        "duration": copy.deepcopy(info["duration"]),
        "message_count": info["message_count"],
    }]
    path = Path(bag_dir) / "metadata.yaml"
    text = "".join(f"  {line}" if line else line for line in bag_metadata_yaml(listed).splitlines(keepends=True))
    path.write_text("rosbag2_bagfile_information:\n" + text, encoding="utf-8")
    return path


def bag_info(
    topics: Sequence[tuple[str, str, str, Sequence[Mapping[str, Any]], str, int]],
    *,
    message_count: int,
    start_ns: int,
    end_ns: int,
) -> dict[str, Any]:
    """rosbag2's BagMetadata (version 9) as yaml-cpp would encode it, keys in rosbag2's order; it lists no
    file (:func:`write_bag_metadata` names the bag folder's file), so what embeds it does not depend on the
    name it is written under.

    Args:
        topics: (name, type, serialization format, offered QoS profiles, type hash, message count).
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
                    "offered_qos_profiles": [dict(profile) for profile in qos],  # QOS_* stay intact (read only)
                    "type_description_hash": type_hash,
                },
                "message_count": count,
            }
            for name, msgtype, serialization, qos, type_hash, count in topics
        ],
        "compression_format": "",
        "compression_mode": "",
        "relative_file_paths": [],
        "files": [],
        "custom_data": None,
        "ros_distro": ROS_DISTRO,
    }


_PLAIN = re.compile(r"[A-Za-z_/][A-Za-z0-9_/]*")
"""Strings written plain by :func:`yaml_dump` and read back as themselves when they hold a ``/`` or ``_`` (no YAML
1.1 number, boolean, null or timestamp does): ROS names, types and hashes."""


_WORDS = {"": '""', "cdr": "cdr", "ros1": "ros1"}
"""Other values a topic entry's template takes, as :func:`yaml_dump` writes them."""


def _plain(value: Any) -> bool:
    return isinstance(value, str) and ("/" in value or "_" in value) and _PLAIN.fullmatch(value) is not None


def bag_metadata_yaml(info: Mapping[str, Any]) -> str:
    """:func:`yaml_dump` of a :func:`bag_info` mapping, linear in its topics: each topic entry of plain names
    (``/topic``, ``pkg/msg/Type``, ``RIHS01_…``) is written from a template made once per QoS profile list,
    the others by PyYAML (the same text; PyYAML's pure-Python emitter took 38 s for 60,000 topics)."""
    from tfrec._yaml import yaml_dump

    topics = info.get("topics_with_message_count")
    if not isinstance(topics, list) or len(topics) < 2:
        return yaml_dump(info)
    head, tail = yaml_dump({**info, "topics_with_message_count": ["TFREC_TOPICS"]}).split("  - TFREC_TOPICS\n")
    templates: dict[str, str] = {}
    parts = [head]
    for entry in topics:
        meta = entry["topic_metadata"]
        fields = (meta["name"], meta["type"], meta["serialization_format"], meta["type_description_hash"])
        if not (all(_plain(field) or field in _WORDS for field in fields) and type(entry["message_count"]) is int):
            parts.append(yaml_dump({"topics_with_message_count": [entry]}).split("\n", 1)[1])
            continue
        key = repr(meta["offered_qos_profiles"])
        template = templates.get(key)
        if template is None:
            probe = {"topic_metadata": {**meta, "name": "TFREC_N/", "type": "TFREC_T/", "serialization_format": "TFREC_S/",
                                        "type_description_hash": "TFREC_H/"}, "message_count": "TFREC_C/"}
            template = templates[key] = yaml_dump({"topics_with_message_count": [probe]}).split("\n", 1)[1]
        name, msgtype, serialization, type_hash = (_WORDS.get(field, field) for field in fields)
        parts.append(template.replace("TFREC_N/", name).replace("TFREC_T/", msgtype)
                     .replace("TFREC_S/", serialization).replace("TFREC_H/", type_hash)
                     .replace("TFREC_C/", str(entry["message_count"])))
    parts.append(tail)
    return "".join(parts)


@dataclass(frozen=True, slots=True)
class BagMetadata:
    """What tfrec needs of a rosbag2 folder's ``metadata.yaml``.

    Attributes:
        storage: the storage plugin, ``mcap`` or ``sqlite3``.
        files: the bag's files, in order.
        compression: ``compression_format`` (``zstd`` for a compressed bag), or ``""``.
        compression_mode: ``file`` (each file compressed whole: ``bag_0.db3.zstd``) or
            ``message`` (each message compressed), when ``compression`` is set.
        topic_counts: messages per topic as ``topics_with_message_count`` says (names as
            recorded), or None without a metadata.yaml (:func:`bag_without_metadata`).
    """

    storage: str
    files: tuple[Path, ...]
    compression: str
    compression_mode: str = ""
    topic_counts: dict[str, int] | None = None


def read_bag_metadata(folder: Path) -> BagMetadata:
    """Read a rosbag2 folder's ``metadata.yaml``.

    Raises:
        ReadError: no or malformed metadata.yaml (one line naming the file, and the line
            of a YAML syntax error), or a listed file that is missing.
    """
    meta = folder / "metadata.yaml"
    if not meta.is_file():
        raise ReadError(f"{folder}: a folder without metadata.yaml is not a rosbag2 bag")
    try:
        with open(meta, "rb") as stream:
            data = stream.read(METADATA_MAX_BYTES + 1)
    except OSError as err:
        raise ReadError(f"{meta}: cannot read: {err.strerror or err}") from err
    if len(data) > METADATA_MAX_BYTES:
        raise ReadError(f"{meta}: larger than the {METADATA_MAX_BYTES >> 20} MiB a metadata.yaml may have")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as err:
        raise ReadError(f"{meta}: not UTF-8 text (byte {err.start:,})") from err
    from tfrec._yaml import load_yaml

    # bounded: an alias bomb or 20,000-deep nesting is refused at once (tfrec._yaml)
    document = load_yaml(text, where=str(meta), error=ReadError)
    info = document.get("rosbag2_bagfile_information") if isinstance(document, dict) else None
    if not isinstance(info, dict):
        raise ReadError(f"{meta}: not a rosbag2 metadata file (no rosbag2_bagfile_information mapping)")
    names = info.get("relative_file_paths")
    if not isinstance(names, list) or not names:
        raise ReadError(f"{meta}: rosbag2_bagfile_information lists no relative_file_paths")
    _check_topics(info.get("topics_with_message_count"), meta)
    files = _storage_files(folder, meta, names)
    compression = str(info.get("compression_format") or "")
    mode = str(info.get("compression_mode") or "").lower() if compression else ""
    return BagMetadata(str(info.get("storage_identifier") or ""), files, compression, mode, _topic_counts(info))


def _storage_files(folder: Path, meta: Path, names: list[Any]) -> tuple[Path, ...]:
    """The files ``relative_file_paths`` lists, each once: a name is taken as a file of the bag's own folder
    (its last part: ``../x.mcap``, ``sub/../x.mcap`` and ``./x.mcap`` are ``x.mcap``; nothing outside the
    folder is read), and names of one file (repeated, or links to it) are read once, with a warning.

    Raises:
        ReadError: more than :data:`MAX_STORAGE_FILES` files, or a listed file that is missing.
    """
    unique = list(dict.fromkeys(Path(str(name)).name for name in names))
    if len(unique) > MAX_STORAGE_FILES:
        raise ReadError(f"{meta}: relative_file_paths lists {len(unique):,} files, more than a bag has "
                        f"(at most {MAX_STORAGE_FILES:,})")
    files: dict[tuple[int, int], Path] = {}
    for name in unique:
        file = folder / name
        try:
            status = file.stat()
        except OSError:
            status = None
        if status is None or not stat.S_ISREG(status.st_mode):
            raise ReadError(f"{folder}: metadata.yaml lists {name}, which is missing")
        files.setdefault((status.st_dev, status.st_ino), file)
    if len(files) < len(names):
        repeated = len(names) - len(files)
        warnings.warn(f"{meta}: relative_file_paths names {len(files):,} file{'s' if len(files) != 1 else ''} "
                      f"{len(names):,} times ({repeated:,} repeated, or names of one file): each is read once", TfrecWarning,
                      stacklevel=4)
    return tuple(files.values())


def _topic_counts(info: dict[str, Any]) -> dict[str, int] | None:
    """``topics_with_message_count`` as topic → messages (summed over entries of one topic); None when
    missing or malformed."""
    entries = info.get("topics_with_message_count")
    if not isinstance(entries, list):
        return None
    counts: dict[str, int] = {}
    for entry in entries:
        try:
            name, count = str(entry["topic_metadata"]["name"]), int(entry["message_count"])
        except (KeyError, TypeError, ValueError):
            return None
        counts[name] = counts.get(name, 0) + count
    return counts


_STORAGES = {".mcap": "mcap", ".db3": "sqlite3"}


def bag_without_metadata(folder: Path) -> BagMetadata | None:
    """A rosbag2 folder whose metadata.yaml is missing (what ``ros2 bag reindex`` rebuilds): its
    ``.mcap`` (or ``.db3``) files named as rosbag2 names the files of one bag — one stem, split indexes
    0, 1, 2… (``bag_0.mcap``, ``bag_1.mcap``) — in that order, as one bag; None for any other folder
    (a folder of separate recordings, ``a.mcap`` and ``b.mcap``, is not a bag)."""
    for suffix, storage in _STORAGES.items():
        files = [file for file in folder.iterdir() if file.suffix == suffix and file.is_file()]
        if not files:
            continue
        parts = [file.stem.rpartition("_") for file in files]
        stems = {stem for stem, sep, number in parts if sep and number.isdigit()}
        indexes = sorted(int(number) for _, _, number in parts if number.isdigit())
        if len(stems) != 1 or indexes != list(range(len(files))):
            return None
        return BagMetadata(storage, tuple(sorted(files, key=lambda file: int(file.stem.rpartition("_")[2]))), "")
    return None


def _check_topics(topics: Any, meta: Path) -> None:
    """The topics of a metadata.yaml, where it lists them, name each topic and its type as text (a list or a
    number there went through rosbags into tfrec's tables as a key)."""
    if topics is None:
        return
    if not isinstance(topics, list):
        raise ReadError(f"{meta}: topics_with_message_count is not a list")
    for k, entry in enumerate(topics):
        topic = entry.get("topic_metadata") if isinstance(entry, dict) else None
        if not isinstance(topic, dict):
            raise ReadError(f"{meta}: topics_with_message_count[{k}] has no topic_metadata mapping")
        for key in ("name", "type", "serialization_format"):
            if key in topic and not isinstance(topic[key], str):
                raise ReadError(f"{meta}: topics_with_message_count[{k}].topic_metadata.{key} is not text: "
                                f"{type(topic[key]).__name__}")


def one_line(text: str) -> str:
    """A library's error message on one line: runs of whitespace (newlines too) become one space."""
    return " ".join(text.split())


_DURABILITY = {0: "system_default", 1: "transient_local", 2: "volatile", 3: "unknown", 4: "best_available"}
_ENUMS = {
    "history": {0: "system_default", 1: "keep_last", 2: "keep_all", 3: "unknown"},
    "reliability": {0: "system_default", 1: "reliable", 2: "best_effort", 3: "unknown", 4: "best_available"},
    "durability": _DURABILITY,
    "liveliness": {0: "system_default", 1: "automatic", 2: "manual_by_node", 3: "manual_by_topic", 4: "unknown",
                   5: "best_available"},
}
"""The QoS enums as rosbag2 of Humble and older wrote them (numbers), and as Jazzy's metadata version 9 names them."""


def offered_qos_profiles(text: str, *, latched: bool) -> list[dict[str, Any]]:
    """Offered QoS profiles as metadata version 9 writes them, from rosbag2's YAML text of any
    version (Humble's numbered enums are named); a missing or unreadable text gives the profile
    tfrec records with: :data:`QOS_LATCHED` when ``latched``, else :data:`QOS_VOLATILE`."""
    profiles = _parsed_qos(text)
    if not isinstance(profiles, list) or not profiles or not all(isinstance(p, dict) for p in profiles):
        return [dict(QOS_LATCHED if latched else QOS_VOLATILE)]  # nested values shared: read only
    out = []
    for profile in profiles:
        named = dict(profile)
        for key, names in _ENUMS.items():
            value = named.get(key)
            if isinstance(value, int) and not isinstance(value, bool):
                named[key] = names.get(value, "unknown")
        out.append(named)
    return out


@lru_cache(maxsize=256)
def _parsed_qos(text: str) -> Any:
    """``offered_qos_profiles`` text parsed (None: empty or not YAML), once per text: thousands of channels
    share a few. Callers copy what they keep (the result is shared)."""
    known = _KNOWN_QOS.get(text)
    if known is not None:
        return copy.deepcopy(known)
    from tfrec._yaml import load_yaml

    try:
        return copy.deepcopy(load_yaml(text, where="offered_qos_profiles")) if text else None
    except ValueError:
        return None


def qos_durability(offered_qos_profiles: str) -> str | None:
    """The durability of the first offered QoS profile, from rosbag2's YAML text (the
    ``offered_qos_profiles`` of MCAP channel metadata, of sqlite3's topics table); None when
    there is none (or the text is not YAML). Numbers (Humble and older) are named as the strings
    Jazzy writes."""
    try:
        value = _parsed_qos(offered_qos_profiles)[0]["durability"]
    except (TypeError, KeyError, IndexError):
        return None
    return _DURABILITY.get(value, "unknown") if isinstance(value, int) else str(value)
