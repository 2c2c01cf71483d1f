"""ROS messages as bytes: vectorized encoding of the messages tfrec writes, as CDR or ROS 1 bytes
(:mod:`.encode`), bulk decoding (:mod:`.decode`; a joint named twice: :mod:`.joint_names`), rosbags' type
stores and deserializers (:mod:`.types`), the message definitions a recording carries, checked and compared
with the layouts tfrec reads (:mod:`.definitions`), and raw messages with their connections (:mod:`.connection`)."""

from __future__ import annotations

__all__ = ["connection", "decode", "definitions", "encode", "joint_names", "types"]
