"""The copy itself: a recording's messages, batch by batch — selected, cut, carried over, written.

:class:`Copier` reads a :class:`~tfrec.formats.ros.connection.MessageSource` once, a chunk at a
time, so memory stays flat whatever the recording's length. Each connection is planned when it is
first met: left out (not selected), dropped (its type cannot be carried to the output's
serialization: the reason is kept for one warning), or written (as it is, or converted,
:func:`tfrec.formats.translate.translation`). With a cut (``lo``), the last message before it of
every latched connection (transient_local, ``latching=1``: /tf_static, /robot_description, a map)
is kept and written at the cut, before anything else, keeping its QoS or latching — what a late
subscriber of the running system would have received. TF computed from joint states
(:mod:`tfrec.convert.joints`) is written beside the joint states it comes from. An MCAP input's attachments
(a calibration file) and metadata records are copied to an MCAP output, after the messages; where the output
cannot hold them the report names them.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from tfrec.conventions import ROBOT_DESCRIPTION, TF_STATIC, robot_topic_kind
from tfrec.convert.joints import Derivation
from tfrec.errors import ConvertError
from tfrec.formats.output import MessageWriter
from tfrec.formats.ros.connection import Connection, MessageBatch, MessageSource, raw_messages
from tfrec.formats.ros.definitions import has_known_layout
from tfrec.formats.rosbag2.metadata import qos_durability
from tfrec.formats.translate import Translation, Untranslatable, standard_connection, string_message, translation

__all__ = ["Copier", "CopyReport"]

_TF_TYPE = "tf2_msgs/msg/TFMessage"
_RSP = "/robot_state_publisher"
"""The caller id of the connections that carry what robot_state_publisher would have published (ROS 1)."""


@dataclass
class CopyReport:
    """What a copy wrote and what it did not.

    Attributes:
        written: topic → messages written.
        dropped: topic → (messages, why): messages that could not be carried over.
        left_out: topic → messages not selected (``topics``, ``exclude``, ``namespace``).
        replaced: topic → recorded descriptions replaced by the given one (``robot``).
        notes: topic → something to tell about it (a definition that does not fit its messages).
        latched: topics whose last message before the cut was written at the cut.
        derived: robot key → (moving joints, fixed frames) whose TF was computed.
        extras: the input's attachments and metadata records copied (``attachment 'calibration.yaml'``).
        extras_left_out: those not written, and why (the output cannot hold them, a CRC fails).
        read_error: what was lost of a damaged input, or None.
    """

    written: dict[str, int] = field(default_factory=dict)
    dropped: dict[str, tuple[int, str]] = field(default_factory=dict)
    left_out: dict[str, int] = field(default_factory=dict)
    replaced: dict[str, int] = field(default_factory=dict)
    notes: dict[str, str] = field(default_factory=dict)
    latched: list[str] = field(default_factory=list)
    derived: dict[str, tuple[int, int]] = field(default_factory=dict)
    extras: list[str] = field(default_factory=list)
    extras_left_out: list[tuple[str, str]] = field(default_factory=list)
    read_error: str | None = None

    @property
    def messages(self) -> int:
        """Messages written."""
        return sum(self.written.values())


@dataclass
class _Plan:
    """What is done with one connection's messages."""

    topic: str
    selected: bool
    latched: bool = False
    translation: Translation | None = None
    reason: str = ""
    out: int = -1
    replaced: bool = False
    derivations: list[Derivation] = field(default_factory=list)


def _latched_by_convention(connection: Connection) -> bool:
    """A ROS 2 /tf_static or /robot_description (of any namespace) whose file gives no durability: latched,
    as tf2's static broadcaster and robot_state_publisher always publish them."""
    kind = robot_topic_kind(connection.topic)
    return (kind is not None and kind[1] in (TF_STATIC, ROBOT_DESCRIPTION) and not connection.ros1
            and qos_durability(connection.qos) is None)


class Copier:
    """Copies a source's messages into a writer.

    Args:
        source: the input's messages.
        writer: the output.
        selected: whether a topic (as played: remapped) is written.
        lo, hi: the cut: messages logged from ``lo`` to ``hi`` (ns since the epoch) are written;
            None: no bound.
        start_ns: when what the copy adds (computed /tf_static, a given description) is logged
            without a cut: the input's first log time.
        derivations: robots whose TF is computed from their joint states.
    """

    def __init__(self, source: MessageSource, writer: MessageWriter, *, selected: Callable[[str], bool],
                 lo: int | None, hi: int | None, start_ns: int, derivations: list[Derivation]) -> None:
        self.source = source
        self.writer = writer
        self.selected = selected
        self.lo = lo
        self.hi = hi
        self.start_ns = start_ns
        self.derivations = derivations
        self.report = CopyReport()
        self._plans: dict[int, _Plan] = {}
        self._latched: dict[int, tuple[int, bytes]] = {}  # conn → (log time, message)
        self._begun = False
        self._ros1 = writer.encoding == "ros1"

    def run(self) -> CopyReport:
        """Copy every batch, then report.

        Raises:
            ReadError: the input cannot be read (a damaged one is read as far as it goes).
            WriteError: the output cannot be written.
            ConvertError: joint states that cannot be decoded for computing TF.
        """
        # chunks wholly after the cut need not be read; an MCAP's publish times, attachments and metadata are copied
        for batch in self.source.batches(until_ns=self.hi, publish_time=True, extras=True):
            self._batch(batch)
        for conn in list(self.source.connections):  # topics without messages are listed too, as rosbag2 lists them
            self._plan(conn)
        self._begin()
        if self.source.extras:  # an MCAP's attachments and metadata: copied while the input is open
            left = self.writer.copy_extras(self.source.extras)
            self.report.extras_left_out = left
            lost = {shown for shown, _ in left}
            self.report.extras = [extra.shown for extra in self.source.extras if extra.shown not in lost]
        for plan in self._plans.values():
            if plan.translation is not None and plan.translation.failed:
                count, _ = self.report.dropped.get(plan.topic, (0, ""))
                self.report.dropped[plan.topic] = (count + plan.translation.failed,
                                                   f"rosbags cannot convert them ({plan.translation.reason})")
        for d in self.derivations:
            if d.joints or d.static:
                self.report.derived[d.key] = (len(d.joints) if d.messages else 0, len(d.static))
        self.report.read_error = self.source.read_error
        return self.report

    # -- planning -------------------------------------------------------------------------------

    def _plan(self, conn: int, sample: bytes | memoryview | None = None) -> _Plan:
        plan = self._plans.get(conn)
        if plan is not None:
            return plan
        c = self.source.connections[conn]
        if not c.latched and _latched_by_convention(c):
            c = replace(c, latched=True, qos="")
        plan = self._plans[conn] = _Plan(c.topic, self.selected(c.topic), c.latched)
        plan.derivations = [d for d in self.derivations if d.joints and d.joint_topic == c.topic
                            and c.msgtype == "sensor_msgs/msg/JointState" and has_known_layout(c)]
        plan.replaced = any(d.description is not None and d.description_topic == c.topic for d in self.derivations)
        if plan.selected and not plan.replaced:
            try:
                plan.translation = translation(c, encoding=self.writer.encoding, sample=sample)
            except Untranslatable as err:
                plan.reason = f"{c.msgtype or 'no type'}: {err.reason}"
            else:
                plan.out = self.writer.add(plan.translation.target)
                if plan.translation.note:
                    self.report.notes[c.topic] = f"{c.msgtype}: {plan.translation.note}"
        return plan

    # -- batches --------------------------------------------------------------------------------

    def _batch(self, batch: MessageBatch) -> None:
        conns, times = batch.conn, batch.log_time
        found, first = np.unique(conns, return_index=True)
        for conn, at in zip(found.tolist(), first.tolist()):
            if conn not in self._plans:
                self._plan(conn, batch.data[at])
        inside = np.ones(len(batch), dtype=bool)
        if self.lo is not None:
            before = times < self.lo
            if before.any():
                self._keep_latched(batch, before)
            inside &= ~before
        if self.hi is not None:
            inside &= times <= self.hi
        if not inside.any():
            return
        self._begin()
        kept = np.flatnonzero(inside)
        order = kept[np.argsort(conns[kept], kind="stable")]  # grouped by connection once: linear in connections
        groups, starts = np.unique(conns[order], return_index=True)
        for conn, index in zip(groups.tolist(), np.split(order, starts[1:])):
            self._write(self._plans[conn], batch.take(index), self.source.connections[conn].ros1)

    def _write(self, plan: _Plan, part: MessageBatch, ros1: bool) -> None:
        for d in plan.derivations:
            self._derive(d, part, ros1)
        report, topic, n = self.report, plan.topic, len(part)
        if not plan.selected:
            report.left_out[topic] = report.left_out.get(topic, 0) + n
        elif plan.replaced:
            report.replaced[topic] = report.replaced.get(topic, 0) + n
        elif plan.translation is None:
            count, _ = report.dropped.get(topic, (0, ""))
            report.dropped[topic] = (count + n, plan.reason)
        else:
            payload, kept = plan.translation.apply(part.data)
            times, publish = part.log_time, part.publish_time if plan.translation.convert is None else None
            if kept is not None:
                times, publish = times[kept], None if publish is None else publish[kept]
            self.writer.write(plan.out, times, payload, publish)
            report.written[topic] = report.written.get(topic, 0) + len(times)

    def _keep_latched(self, batch: MessageBatch, before: NDArray[np.bool_]) -> None:
        """Keep the last message before the cut of each latched connection (written at the cut)."""
        for conn in np.unique(batch.conn[before]).tolist():
            plan = self._plans[conn]
            if not (plan.latched and plan.selected and plan.translation is not None):
                continue
            last = int(np.flatnonzero(before & (batch.conn == conn))[-1])
            time_ns = int(batch.log_time[last])
            if conn not in self._latched or self._latched[conn][0] <= time_ns:
                self._latched[conn] = (time_ns, bytes(batch.data[last]))
                if self._begun:  # an input out of time order: it still goes at the cut
                    self._write_latched(conn)

    def _begin(self) -> None:
        """Before the first message of the window: what the copy adds, then the latched messages."""
        if self._begun:
            return
        self._begun = True
        at = self.lo if self.lo is not None else self.start_ns
        stamp = np.array([at], dtype=np.int64)
        for d in self.derivations:
            if d.description is not None and self.selected(d.description_topic):
                out = self.writer.add(standard_connection(d.description_topic, "std_msgs/msg/String",
                                                          encoding=self.writer.encoding, latched=True, callerid=_RSP))
                self.writer.write(out, stamp, [string_message(d.description, ros1=self._ros1)])
                self.report.written[d.description_topic] = self.report.written.get(d.description_topic, 0) + 1
            rows = d.static_message(stamp_ns=at, out_ros1=self._ros1)
            if rows is not None and self.selected(d.static_topic):
                out = self.writer.add(standard_connection(d.static_topic, _TF_TYPE, encoding=self.writer.encoding,
                                                          latched=True, callerid=_RSP))
                self.writer.write(out, stamp, rows)
                self.report.written[d.static_topic] = self.report.written.get(d.static_topic, 0) + 1
        for conn in sorted(self._latched):
            self._write_latched(conn)

    def _write_latched(self, conn: int) -> None:
        plan = self._plans[conn]
        assert self.lo is not None and plan.translation is not None
        _, message = self._latched[conn]
        payload, kept = plan.translation.apply(raw_messages([message]))
        if kept is not None and not len(kept):
            return  # it could not be converted: counted as dropped
        self.writer.write(plan.out, np.array([self.lo], np.int64), payload, np.array([self.lo], np.int64))
        self.report.written[plan.topic] = self.report.written.get(plan.topic, 0) + 1
        if plan.topic not in self.report.latched:
            self.report.latched.append(plan.topic)

    def _derive(self, d: Derivation, part: MessageBatch, ros1: bool) -> None:
        """The /tf robot_state_publisher would publish for these joint states, logged with them."""
        if not self.selected(d.tf_topic):
            return
        try:
            computed = list(d.transforms(part.data, ros1=ros1, out_ros1=self._ros1))
        except ValueError as err:  # rosbags cannot decode a message that does not fit the layout
            raise ConvertError(f"{self.source.where}: a {d.joint_topic} message cannot be decoded as "
                               f"sensor_msgs/JointState ({err})") from err
        if not computed:
            return
        out = self.writer.add(standard_connection(d.tf_topic, _TF_TYPE, encoding=self.writer.encoding, latched=False,
                                                  callerid=_RSP))
        for rows, messages in computed:
            self.writer.write(out, part.log_time[rows], messages)
            self.report.written[d.tf_topic] = self.report.written.get(d.tf_topic, 0) + len(rows)
