"""What a recording holds, format aside: the :class:`Recording` every reader builds, and the TF types the stages share.

The readers in :mod:`tfrec.formats` build one (:func:`tfrec.formats.read_recording`); ``info``,
``replay``, ``diff``, ``convert`` and ``check`` only read it. TF comes in two shapes, both here: frame pairs that
share their stamps (:class:`Transforms`: what forward kinematics computes, what the sinks write and the viewer
logs; at one instant, :meth:`Transforms.poses` gives the ``(parent, child) → (translation, rotation)`` mapping of
latched transforms) and one recorded pair with stamps of its own (:class:`FrameSeries`: a recording's pairs are
published at different instants).
"""

from __future__ import annotations

import io
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from xml.etree import ElementTree

import numpy as np
from numpy.typing import NDArray

from tfrec.conventions import robot_topic_kind
from tfrec.model import Robot

__all__ = [
    "FrameSeries",
    "JointStates",
    "Recording",
    "TopicInfo",
    "TopicStats",
    "Transforms",
    "robot_name",
]

Array = NDArray[np.float64]
Pair = tuple[str, str]


@dataclass(frozen=True, slots=True)
class TopicInfo:
    """One topic of a recording.

    Attributes:
        type: the message type as the recording names it (``tf2_msgs/msg/TFMessage``).
        count: messages on the topic.
        first_ns, last_ns: log times (receive times) of the first and last message, ns since
            the epoch; None for data without a time (static data in an ``.rrd``).
        durability: the offered QoS durability (``transient_local``, ``volatile``…) where the
            format records it (MCAP channels, rosbag2 topics); ``latched`` for a latching
            topic of a ROS 1 bag; else None.
    """

    type: str
    count: int
    first_ns: int | None
    last_ns: int | None
    durability: str | None = None


class TopicStats:
    """A reader's running count of one topic's (or one channel's) messages; becomes a :class:`TopicInfo`.

    Attributes: as :class:`TopicInfo`'s; ``first_ns`` and ``last_ns`` are None until a message
    with a time is counted.
    """

    __slots__ = ("count", "durability", "first_ns", "last_ns", "type")

    def __init__(self, msgtype: str, durability: str | None = None) -> None:
        self.type = msgtype
        self.durability = durability
        self.count = 0
        self.first_ns: int | None = None
        self.last_ns: int | None = None

    def add(self, time_ns: int) -> None:
        """Count one message logged at ``time_ns``."""
        if self.first_ns is None or time_ns < self.first_ns:
            self.first_ns = time_ns
        if self.last_ns is None or time_ns > self.last_ns:
            self.last_ns = time_ns
        self.count += 1

    def add_times(self, first_ns: int | None, last_ns: int | None) -> None:
        """Widen the time span to include [``first_ns``, ``last_ns``] (None: no time)."""
        if first_ns is not None and (self.first_ns is None or first_ns < self.first_ns):
            self.first_ns = first_ns
        if last_ns is not None and (self.last_ns is None or last_ns > self.last_ns):
            self.last_ns = last_ns

    def merge(self, other: TopicStats) -> None:
        """Add the messages ``other`` counted (another channel or file of the same topic)."""
        self.count += other.count
        self.add_times(other.first_ns, other.last_ns)
        self.durability = self.durability or other.durability

    def info(self) -> TopicInfo:
        return TopicInfo(self.type, self.count, self.first_ns, self.last_ns, self.durability)


@dataclass(frozen=True, slots=True)
class JointStates:
    """Every /joint_states message as one array.

    Attributes:
        time_ns: int64 (N,) header stamps, non-decreasing.
        names: the union of the joint names of all messages, in order of first appearance.
        positions: float64 (N, J); NaN where a message has no position for a joint.
        repeated: joints that some message names more than once; their first position is the one
            taken, as robot_state_publisher takes it.
    """

    time_ns: NDArray[np.int64]
    names: tuple[str, ...]
    positions: Array
    repeated: tuple[str, ...] = ()

    def __len__(self) -> int:
        return len(self.time_ns)


@dataclass(frozen=True, slots=True)
class Transforms:
    """K transforms ``parent_from_child`` at N instants.

    Attributes:
        parents: frame ids of the parent frames (frame prefix included), length K.
        children: frame ids of the child frames, length K.
        translation: float64 (N, K, 3), metres: the child origin in the parent frame.
        rotation: float64 (N, K, 4), unit quaternions (x, y, z, w) with w >= 0.
    """

    parents: tuple[str, ...]
    children: tuple[str, ...]
    translation: Array
    rotation: Array

    def __post_init__(self) -> None:
        k = len(self.children)
        n = self.translation.shape[0] if self.translation.ndim == 3 else -1
        if len(self.parents) != k or self.translation.shape != (n, k, 3) or self.rotation.shape != (n, k, 4):
            raise ValueError(
                f"inconsistent transforms: {len(self.parents)} parents, {k} children, "
                f"translation {self.translation.shape}, rotation {self.rotation.shape}"
            )

    def __len__(self) -> int:
        """N, the number of instants."""
        return int(self.translation.shape[0])

    @classmethod
    def from_poses(cls, poses: Mapping[tuple[str, str], tuple[Array, Array]]) -> Transforms:
        """Transforms at one instant (N = 1) of frame pairs, (parent, child) → (translation (3,), rotation (4,))."""
        k = len(poses)
        return cls(
            tuple(parent for parent, _ in poses),
            tuple(child for _, child in poses),
            np.array([t for t, _ in poses.values()], dtype=np.float64).reshape(1, k, 3),
            np.array([r for _, r in poses.values()], dtype=np.float64).reshape(1, k, 4),
        )

    def poses(self, instant: int = 0) -> dict[tuple[str, str], tuple[Array, Array]]:
        """The transforms at one instant, (parent, child) → (translation (3,), rotation (4,)) (views).

        The form a replay holds latched transforms in; :meth:`from_poses` is the inverse.
        """
        return {
            (parent, child): (self.translation[instant, k], self.rotation[instant, k])
            for k, (parent, child) in enumerate(zip(self.parents, self.children))
        }


@dataclass(frozen=True, slots=True)
class FrameSeries:
    """The transforms of one (parent, child) pair on /tf, in time order.

    Attributes:
        time_ns: int64 (M,) stamps of the transforms.
        translation: float64 (M, 3), metres.
        rotation: float64 (M, 4), quaternions (x, y, z, w) as recorded.
    """

    time_ns: NDArray[np.int64]
    translation: Array
    rotation: Array

    def __len__(self) -> int:
        return len(self.time_ns)


@dataclass(frozen=True)
class RecordedRobot:
    """A robot's recorded data: the one type a robot has, from a namespace's robot topics as a reader finds them
    (:meth:`Recording.robot_topics`), through a robot of the recording (:func:`tfrec.robots.find_robots`), to a
    robot as a replay plays it (:attr:`tfrec.replay.Replay.robots`).

    A namespace's topics are ``<ns>/robot_description``, ``<ns>/joint_states``, ``<ns>/tf`` and ``<ns>/tf_static``
    (``ns`` empty for the root namespace); a robot of the recording is one description of them (or the data of a
    namespace without one), with the TF it reads — a TF shared by several robots is split by frame.

    Attributes:
        namespace: the namespace of its description (or of its topics, without one).
        descriptions: the robot descriptions (URDF texts): every one on the namespace's /robot_description — several
            robots may publish on one topic —, the last text of each robot name, in order of first appearance; a
            robot's own, one.
        joint_states: the joint states it reads (its namespace's, else the root's), or None.
        tf: (parent, child) → :class:`FrameSeries` of its /tf.
        tf_static: (parent, child) → (translation (3,), rotation (4,)) of its /tf_static.
        key: unique within the recording: ``""`` for the only robot of the root namespace, else its namespace
            (``/robot1``), or with several robots in one namespace the namespace and the robot's name
            (``left_arm``, ``/fleet/left_arm``); also the entity path under which ``replay`` shows it.
        name: the ``<robot name>`` of its description, or None.
        model: the description parsed (or the one given to replay it), or None (none, or unusable: ``problem``
            says why).
        problem: why the description is not a usable robot model, or None.
        frame_prefix: what its frame ids put in front of its link names.
        joint_states_namespace: the namespace its joint states come from.
        tf_namespace: the namespace of the /tf and /tf_static its TF comes from.
        unclaimed: not a robot: the pairs of a TF shared by several robots that none of them claims (key
            ``…/other_frames``).
        derived_static: (replayed) the pairs of ``tf_static`` that are fixed joints of the model, not recorded.
        derived_dynamic: (replayed) the pairs of ``tf`` computed from the model and the joint states.
        display_prefix: (replayed) put in front of its frame ids in the viewer, where robots of several namespaces
            use the same frame ids (``robot1/``); ``""`` otherwise.
    """

    namespace: str = ""
    descriptions: tuple[str, ...] = ()
    joint_states: JointStates | None = None
    tf: dict[Pair, FrameSeries] = field(default_factory=dict)
    tf_static: dict[Pair, tuple[Array, Array]] = field(default_factory=dict)
    key: str = ""
    name: str | None = None
    model: Robot | None = None
    problem: str | None = None
    frame_prefix: str = ""
    joint_states_namespace: str = ""
    tf_namespace: str = ""
    unclaimed: bool = False
    derived_static: frozenset[Pair] = frozenset()
    derived_dynamic: frozenset[Pair] = frozenset()
    display_prefix: str = ""

    @property
    def robot_description(self) -> str | None:
        """The (last) robot description: that of the robot that published last; None without one."""
        return self.descriptions[-1] if self.descriptions else None

    def has_data(self) -> bool:
        """Whether it holds anything: a description, joint states or TF."""
        return bool(self.descriptions or self.joint_states is not None or self.tf or self.tf_static)

    @property
    def label(self) -> str:
        """``robot /robot1``, ``robot left_arm``, ``robot /`` (the root namespace's, beside others); ``the robot``
        for the only one."""
        return f"robot {self.key}" if self.key else "the robot"

    @property
    def entity_root(self) -> str:
        """Where ``replay`` logs it in Rerun: ``/robot1``; ``""`` (the top) for the root namespace's robot."""
        return "" if self.key in ("", "/") else ("" if self.key.startswith("/") else "/") + self.key

    @property
    def derived(self) -> frozenset[Pair]:
        """Every pair that robot_state_publisher's part of a replay added (static and dynamic)."""
        return self.derived_static | self.derived_dynamic

    def contents(self) -> str:
        """``marm, 9 frame pairs``: what the robot holds, for messages."""
        pairs = len(self.tf) + len(self.tf_static)
        return (self.name or "no description") + (f", {pairs} frame pair{'s' if pairs != 1 else ''}" if pairs else "")

    def frames(self) -> list[str]:
        """Every frame id of its TF, latched first, in order of appearance."""
        seen: dict[str, None] = {}
        for parent, child in list(self.tf_static) + list(self.tf):
            seen.setdefault(parent)
            seen.setdefault(child)
        return list(seen)

    def root_frame(self) -> str | None:
        """The frame the 3D view is drawn in: the model's root, else a frame that is nobody's child."""
        if self.model is not None:
            return self.frame_prefix + self.model.root
        children = {child for _, child in list(self.tf_static) + list(self.tf)}
        return next((frame for frame in self.frames() if frame not in children), None)

    def displayed(self) -> RecordedRobot:
        """As the viewer shows it: every frame id behind ``display_prefix``."""
        prefix = self.display_prefix
        if not prefix:
            return self

        def pair(p: Pair) -> Pair:
            return prefix + p[0], prefix + p[1]

        return replace(self, frame_prefix=prefix + self.frame_prefix, display_prefix="",
                       tf_static={pair(p): v for p, v in self.tf_static.items()},
                       tf={pair(p): v for p, v in self.tf.items()},
                       derived_static=frozenset(pair(p) for p in self.derived_static),
                       derived_dynamic=frozenset(pair(p) for p in self.derived_dynamic))


@dataclass
class Recording:
    """What a recording holds, format aside.

    Attributes:
        path: the file or folder read.
        format: ``"mcap"``, ``"rosbag2"``, ``"rosbag1"`` or ``"rrd"``.
        robot_description: the URDF text of the last /robot_description message, or None.
            This and ``joint_states``, ``tf``, ``tf_static`` and ``robot_descriptions`` are the
            root namespace's robot topics; ``namespaces`` holds those of every other namespace
            (:meth:`robot_topics` gives either).
        topics: topic name → :class:`TopicInfo`, in the order the file lists them, names as they
            are played (relative names made global, remapped). An ``.rrd`` has no topics: its
            entities are listed under the topics they stand for.
        joint_states: /joint_states, or None when the recording has none.
        tf: (parent, child) → :class:`FrameSeries` of the transforms on /tf. Frame ids are
            as tf2 sees them: a leading slash (ROS 1) is dropped.
        tf_static: (parent, child) → (translation (3,), rotation (4,)) of the last /tf_static
            transform of that pair.
        robot_descriptions: every robot's description on /robot_description when several
            robots publish there (see :attr:`RecordedRobot.descriptions`); empty when
            ``robot_description`` is the only one.
        namespaces: namespace (``/robot1``) → the :class:`RecordedRobot` data of ``/robot1/tf`` etc., for
            every namespace but the root that holds robot topics.
        time_base: what the stamps of ``joint_states`` and ``tf`` are: ``header`` (the
            messages' header stamps, as tf2 and robot_state_publisher use them) or ``log``
            (the times the messages were logged, ``use_log_time``).
        start_ns, end_ns: log times of the first and last message (ns since the epoch), or
            None for an empty recording. When a damaged file lost messages, the recording's
            true start (and end) as far as the file still tells — an MCAP's summary
            statistics or chunk headers — so times count from the real start, not from the
            first message that could be read.
        read_error: None, or one line saying what a damaged file lost (where reading stopped,
            or which chunks were skipped); the rest of the recording holds what was readable.
        float32: True when the format stores transforms as float32 (``.rrd``).
        details: what ``tfrec info`` shows about the container, where known: ``profile``,
            ``library`` (MCAP header), ``compression`` (chunk compressions, ``none``),
            ``storage`` (rosbag2 storage plugin), ``bag_compression`` (a rosbag2 bag compressed
            ``zstd file`` by file or ``zstd message`` by message).
    """

    path: str
    format: str
    robot_description: str | None = None
    topics: dict[str, TopicInfo] = field(default_factory=dict)
    joint_states: JointStates | None = None
    tf: dict[tuple[str, str], FrameSeries] = field(default_factory=dict)
    tf_static: dict[tuple[str, str], tuple[Array, Array]] = field(default_factory=dict)
    robot_descriptions: tuple[str, ...] = ()
    namespaces: dict[str, RecordedRobot] = field(default_factory=dict)
    time_base: str = "header"
    start_ns: int | None = None
    end_ns: int | None = None
    read_error: str | None = None
    float32: bool = False
    details: dict[str, str] = field(default_factory=dict)

    @property
    def duration_ns(self) -> int:
        return 0 if self.start_ns is None or self.end_ns is None else self.end_ns - self.start_ns

    def robot_topics(self, namespace: str = "") -> RecordedRobot:
        """The robot topics of one namespace (``""``: the root's, from the fields above)."""
        if namespace:
            return self.namespaces.get(namespace) or RecordedRobot(namespace)
        descriptions = self.robot_descriptions
        if self.robot_description not in descriptions:  # none, one, or a description set by hand
            descriptions = () if self.robot_description is None else (self.robot_description,)
        return RecordedRobot("", descriptions, self.joint_states, self.tf, self.tf_static)

    def topic_namespaces(self) -> list[str]:
        """Every namespace of a robot topic in the topic table (``""``: the root's), sorted: where the
        recording has robots, whatever was decoded (for messages that name them)."""
        return sorted({kind[0] for topic in self.topics if (kind := robot_topic_kind(topic)) is not None})

    def namespace_names(self) -> list[str]:
        """Every namespace with robot topics, the root (``""``) first, then in name order."""
        root = [""] if self.robot_topics("").has_data() else []
        return root + sorted(name for name, topics in self.namespaces.items() if name and topics.has_data())


def robot_name(urdf: str) -> str | None:
    """The ``name`` of a URDF's ``<robot>`` element; None when it has none or is not XML."""
    try:
        for _, element in ElementTree.iterparse(io.BytesIO(urdf.encode("utf-8")), events=("start",)):
            return element.get("name") if element.tag == "robot" else None
    except ElementTree.ParseError:
        return None
    return None
