"""What a ROS user types out of habit (``rosbag play``, ``rosbag record -O``, ``ros2 bag play -r``) and the
tfrec command or option that does it: one table, read by :class:`tfrec.cli._common.Parser` when a command
word or an option is not tfrec's, to answer the usage error with "did you mean …?"."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

__all__ = ["HABITS", "Habit", "answer_command", "answer_options"]

FOUR_TOPICS = ("tfrec records the robot's four topics always (/robot_description, /tf_static, /joint_states, /tf)")


@dataclass(frozen=True, slots=True)
class Habit:
    """What a ROS tool takes and what tfrec takes instead.

    Attributes:
        commands: the tfrec commands where it is typed; ``()`` for a command word (``tfrec play``).
        typed: the words or options as typed (``play``; ``bag play``; ``-O``, ``--output-name``).
        instead: tfrec's command (``tfrec replay``) or option (``-o``), with the value typed after
            the option when it takes one; empty when there is none (``note`` then says why).
        metavar: what ``instead`` takes when nothing was typed after the option (``OUT``), or None.
        note: where the habit comes from, or why tfrec has no such option.
    """

    commands: tuple[str, ...]
    typed: tuple[str, ...]
    instead: str
    metavar: str | None
    note: str


HABITS: tuple[Habit, ...] = (
    # command words
    Habit((), ("play", "bag play"), "tfrec replay", None, "rosbag play, ros2 bag play"),
    Habit((), ("bag record",), "tfrec record", None, "ros2 bag record: tfrec records a description's motion"),
    Habit((), ("bag info",), "tfrec info", None, "rosbag info, ros2 bag info"),
    Habit((), ("bag convert", "filter", "bag filter", "compress", "decompress"), "tfrec convert", None,
          "rosbag filter/compress, ros2 bag convert: --topics, --exclude, --start, --end, --compression"),
    Habit((), ("launch", "roslaunch"), "tfrec record PKG FILE.launch", None,
          "roslaunch's PKG FILE form is taken wherever tfrec takes a ROBOT"),
    Habit((), ("check_urdf",), "tfrec inspect", None, "urdfdom's check_urdf"),
    Habit((), ("urdf_to_graphiz", "urdf_to_graphviz"), "tfrec inspect ROBOT --graph", None, "urdfdom's urdf_to_graphiz"),
    Habit((), ("view_frames",), "tfrec info FILE --graph", None, "tf's view_frames"),
    # rosbag record, ros2 bag record
    Habit(("record",), ("-O", "--output-name"), "-o", "OUT", "rosbag record's -O names the bag"),
    Habit(("record",), ("-a", "--all", "-e", "--regex", "-x", "--exclude", "--topics", "--node"), "", None,
          FOUR_TOPICS),
    Habit(("record",), ("-s", "--storage"), "-o", "OUT.mcap",
          "tfrec writes MCAP (--bag DIR: a rosbag2 folder; -o OUT.bag: a ROS 1 bag)"),
    Habit(("record", "convert"), ("-j", "--bz2"), "--compression bz2", None, "rosbag record -j"),
    Habit(("record", "convert"), ("--lz4",), "--compression lz4", None, "rosbag record --lz4"),
    Habit(("record", "convert"), ("--compression-mode", "--compression-format"), "--compression", "zstd",
          "ros2 bag's --compression-mode/--compression-format"),
    Habit(("record",), ("-r",), "--rate", "HZ", "samples per second"),
    # rosbag play, ros2 bag play
    Habit(("replay",), ("-r",), "--rate", "F", "rosbag play -r, ros2 bag play -r"),
    Habit(("replay",), ("-s", "--start-offset"), "--start", "S", "rosbag play -s, ros2 bag play --start-offset"),
    Habit(("replay",), ("-u", "--playback-duration"), "--end", "S",
          "rosbag play -u: tfrec's --end is seconds from the recording's start, not from --start"),
    Habit(("replay",), ("--playback-until-sec", "--playback-until-nsec"), "--end", "S",
          "ros2 bag play: tfrec's --end is seconds from the recording's start"),
    Habit(("replay",), ("-l",), "--loop", None, "rosbag play -l, ros2 bag play -l"),
    Habit(("replay",), ("-i", "--immediate"), "--save", "OUT.rrd", "rosbag play -i: --save writes as fast as it can"),
    Habit(("replay",), ("-m",), "--remap", "FROM:=TO", "ros2 bag play -m"),
    Habit(("replay",), ("--clock",), "", None, "tfrec plays into Rerun on the recording's own stamps: there is no /clock"),
    # rosbag info, ros2 bag info
    Habit(("info",), ("-y", "--yaml"), "--json", None, "rosbag info -y"),
    # ros2 bag convert
    Habit(("convert",), ("-o", "-O", "--output-options"), "tfrec convert IN", "OUT", "OUT is convert's second argument"),
    Habit(("convert",), ("-i", "--input"), "tfrec convert", "IN", "IN is convert's first argument"),
)
"""Every habit tfrec answers."""


def _suggest(found: Sequence[tuple[Habit, str | None]]) -> str:
    """One answer for the habits found (with what was typed after each option): ``did you mean `--rate 2
    --start 1`? (rosbag play -r …; rosbag play -s …)``, then what has no tfrec equivalent."""
    shown: list[str] = []
    notes: list[str] = []
    bare: list[str] = []
    for habit, value in found:
        if not habit.instead:
            bare.append(habit.note)
            continue
        taken = (value or habit.metavar) if habit.metavar is not None else None
        shown.append(" ".join(part for part in (habit.instead, taken) if part))
        notes.append(habit.note)
    parts = [f"did you mean `{' '.join(shown)}`? ({'; '.join(dict.fromkeys(notes))})"] if shown else []
    return "; ".join(parts + list(dict.fromkeys(bare)))


def answer_command(argv: Sequence[str]) -> str | None:
    """The answer to a command word that is not tfrec's (``tfrec play x``, ``tfrec bag play x``), or None."""
    words = [word for word in argv if not word.startswith("-")][:2]
    for count in (2, 1):
        typed = " ".join(words[:count])
        for habit in HABITS:
            if not habit.commands and typed in habit.typed:
                return _suggest([(habit, None)])
    return None


def answer_options(command: str | None, extras: Sequence[str], argv: Sequence[str]) -> str | None:
    """The answer to options of ``command`` that are not tfrec's (``extras``, argparse's unrecognized
    arguments), each one a ROS tool takes, with the value typed after it in ``argv`` (argparse may have
    taken that for a positional): ``-r 2 -s 1`` → did you mean `--rate 2 --start 1`?; or None."""
    found: list[tuple[Habit, str | None]] = []
    unknown = {token for token in extras if token.startswith("-")}
    for i, token in enumerate(argv):
        if command is None or token not in unknown:
            continue
        match = next(((habit, value) for habit in HABITS if command in habit.commands for typed in habit.typed
                      if (value := _value(token, typed, argv[i + 1 :])) is not None), None)
        if match is not None and match[0] not in [habit for habit, _ in found]:
            found.append((match[0], match[1] or None))
    return _suggest(found) if found else None


def _value(token: str, typed: str, rest: Sequence[str]) -> str | None:
    """What was typed for option ``typed`` in ``token`` (``--rate=2``, ``-r2``) or after it; ``""`` when
    nothing; None when ``token`` is not that option."""
    if token == typed:
        return rest[0] if rest and not rest[0].startswith("-") else ""
    if token.startswith(typed + "="):
        return token[len(typed) + 1 :]
    if len(typed) == 2 and not typed.startswith("--") and token.startswith(typed) and not token.startswith("--"):
        return token[2:]  # -r2
    return None
