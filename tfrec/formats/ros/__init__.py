"""ROS messages as bytes: vectorized CDR encoding (:mod:`.cdr`), bulk decoding (:mod:`.decode`) and
rosbags' type stores and deserializers (:mod:`.types`)."""

from __future__ import annotations

__all__ = ["decode", "encode", "types"]
