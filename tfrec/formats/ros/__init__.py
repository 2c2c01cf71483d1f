"""ROS messages as bytes: vectorized encoding of the messages tfrec writes, as CDR or ROS 1 bytes
(:mod:`.encode`), bulk decoding (:mod:`.decode`), rosbags' type stores and deserializers (:mod:`.types`),
and raw messages with their connections (:mod:`.connection`)."""

from __future__ import annotations

__all__ = ["connection", "decode", "encode", "types"]
