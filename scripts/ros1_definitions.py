#!/usr/bin/python3
"""Regenerate tfrec/formats/ros/noetic.msg: the ROS 1 message definitions exactly as ``rosbag record``
writes them (genmsg's text, comments included), for the message packages Debian's ROS 1 ships.

Run with Debian's python3 (it has the generated message classes; the project's venv does not):

    apt-get install python3-{std,geometry,sensor,tf2,rosgraph,actionlib,diagnostic,nav,shape,stereo}-msgs \
        python3-{trajectory,visualization}-msgs
    /usr/bin/python3 scripts/ros1_definitions.py

Each class's ``_full_text`` is genmsg's ``compute_full_text``: the type's own .msg text, then each type it
uses once, after a line of 80 ``=`` and ``MSG: pkg/Type``. The file keeps each type's own text once, in the
same form; tfrec composes the full text again (tfrec.formats.ros.types) and checks it against the classes
here before writing the file.
"""

from __future__ import annotations

import importlib
import sys
from pathlib import Path

PACKAGES = ("actionlib_msgs", "diagnostic_msgs", "geometry_msgs", "nav_msgs", "rosgraph_msgs", "sensor_msgs",
            "shape_msgs", "std_msgs", "stereo_msgs", "tf2_msgs", "trajectory_msgs", "visualization_msgs")
SEPARATOR = "=" * 80 + "\n"
OUT = Path(__file__).resolve().parents[1] / "tfrec" / "formats" / "ros" / "noetic.msg"


def own_text(full_text: str) -> str:
    """A type's own .msg text: genmsg wrote it, then a newline before the first dependency."""
    return full_text.split(SEPARATOR, 1)[0][:-1] if SEPARATOR in full_text else full_text


def main() -> int:
    sys.path.insert(0, str(OUT.parents[3]))
    classes = {}
    for package in PACKAGES:
        module = importlib.import_module(f"{package}.msg")
        for name in dir(module):
            cls = getattr(module, name)
            if isinstance(cls, type) and getattr(cls, "_type", "").startswith(f"{package}/"):
                classes[cls._type] = cls
    texts = {msgtype: own_text(cls._full_text) for msgtype, cls in sorted(classes.items())}
    assert not any(SEPARATOR in text for text in texts.values())
    OUT.write_text("".join(f"{SEPARATOR}MSG: {msgtype}\n{text}\n" for msgtype, text in texts.items()))

    from tfrec.formats.ros.types import genmsg_definition  # the file just written, read as tfrec reads it

    genmsg_definition.cache_clear()
    wrong = [msgtype for msgtype, cls in classes.items() if genmsg_definition(msgtype) != cls._full_text]
    if wrong:
        print(f"composed text differs from genmsg's: {wrong}", file=sys.stderr)
        return 1
    print(f"wrote {OUT} ({len(texts)} types of {len(PACKAGES)} packages)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
