"""ROS messages as bytes: vectorized CDR encoding (:mod:`.cdr`), bulk decoding (:mod:`.decode`) and
rosbags' type stores and deserializers (:mod:`.types`), and raw messages with their connections
(:mod:`.connection`)."""

from __future__ import annotations

__all__ = ["cdr", "connection", "decode", "types"]
