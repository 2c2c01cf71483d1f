"""``tfrec info`` loads the code the file needs and no other: of an MCAP file, a ROS 1 bag or a rosbag2 folder (tfrec's),
not the other formats' readers and writers, not rosbags (the types tfrec reads are known, and its messages read,
without it: tests/formats/test_written_back.py), not PyYAML but for a rosbag2 folder's metadata.yaml, not numpy.ma,
not xacro's sandbox, Rerun or the recorder, and no other subcommand's parser. Measured in a fresh interpreter
(sys.modules after the command); the time it saves is in benchmarks/bench_limits.py and docs/performance.md. The
command line builds only the parser of the subcommand given: its help is the whole parser's."""

from __future__ import annotations

import contextlib
import io
import json
import os
import resource
import subprocess
import sys
from collections.abc import Iterable
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.conftest import ROBOTS
from tfrec.cli import _main, main
from tfrec.cli._main import COMMANDS, _build_parser, _command_module
from tfrec.formats.mcap.writer import message_definition
from tfrec.formats.ros.connection import distinct
from tfrec.formats.ros.definitions import INTERPRETED, ROS_LAYOUTS, foreign_layout
from tfrec.formats.ros.types import ROS2_DEFINITIONS, ros1_message_definition, typestore
from tfrec.formats.rosbag1.records import ros2_msgtype
from tfrec.formats.rosbag2.metadata import (
    _KNOWN_QOS,
    QOS_LATCHED,
    QOS_VOLATILE,
    _parsed_qos,
    qos_durability,
    qos_yaml,
)

_LOADED = """
import contextlib, io, json, sys
from tfrec.cli import main
with contextlib.redirect_stdout(io.StringIO()):
    code = main(["info", sys.argv[1]])
print(json.dumps({"code": code, "modules": sorted(sys.modules)}))
"""

NOT_NEEDED = (
    "rosbags", "numpy.ma", "sqlite3", "mcap", "xacro", "rerun", "matplotlib", "tfrec.formats.rrd",
    "tfrec.formats.rosbag1.writer", "tfrec.formats.rosbag1.sink", "tfrec.formats.rosbag2.source",
    "tfrec.formats.mcap.writer", "tfrec.formats.mcap.sink", "tfrec.description._load", "tfrec.description.xacro",
    "tfrec.viewer", "tfrec.recorder", "tfrec.kinematics", "tfrec.replay", "tfrec.cli._habits",
    *(f"tfrec.cli._{name}" for name in ("inspect", "record", "serve", "diff", "replay", "convert", "plot", "fleet")),
)
"""Not loaded by `info` of any of tfrec's recordings (a name and the modules under it)."""

FORMATS = {
    "mcap": (("tfrec.formats.mcap.source", "tfrec.formats.ros.decode", "tfrec.description.urdf"),
             ("yaml", "tfrec._yaml", "tfrec.formats.rosbag1", "tfrec.formats.rosbag2.storage")),
    "rosbag1": (("tfrec.formats.rosbag1.source", "tfrec.formats.ros.decode", "tfrec.description.urdf"),
                ("yaml", "tfrec._yaml", "zstandard", "tfrec.formats.mcap.source", "tfrec.formats.mcap.summary",
                 "tfrec.formats.rosbag2")),
    "rosbag2": (("tfrec.formats.mcap.source", "tfrec.formats.rosbag2.metadata", "tfrec._yaml", "tfrec.description.urdf"),
                ("tfrec.formats.rosbag1",)),
}
"""Each format: what `info` of tfrec's recording in it loads (it was read), and what it does not, besides NOT_NEEDED."""


def _cpu_limit() -> None:  # the hang guard: 30 CPU seconds
    resource.setrlimit(resource.RLIMIT_CPU, (30, 30))


def _modules_after_info(path: Path) -> list[str]:
    done = subprocess.run([sys.executable, "-c", _LOADED, str(path)], capture_output=True, text=True, check=True,
                          preexec_fn=_cpu_limit)
    result = json.loads(done.stdout)
    assert result["code"] == 0
    return list(result["modules"])


def _under(modules: set[str], names: Iterable[str]) -> list[str]:
    """The modules that are one of ``names`` or under one of them."""
    return sorted(m for m in modules for name in names if m == name or m.startswith(name + "."))


@pytest.fixture(scope="module")
def recordings(tmp_path_factory: pytest.TempPathFactory, marm_mcap: Path) -> dict[str, Path]:
    """tfrec's recordings of marm in each format it writes."""
    folder = tmp_path_factory.mktemp("formats")
    out = {"mcap": marm_mcap, "rosbag1": folder / "marm.bag", "rosbag2": folder / "bag2"}
    with contextlib.redirect_stdout(io.StringIO()):
        for flags in (["-o", str(out["rosbag1"])], ["--bag", str(out["rosbag2"])]):
            assert main(["record", str(ROBOTS / "marm.xacro"), "--duration", "1", "--no-rrd", *flags]) == 0
    return out


@pytest.mark.parametrize("fmt", list(FORMATS))
def test_info_loads_only_what_the_file_needs(recordings: dict[str, Path], fmt: str) -> None:
    modules = set(_modules_after_info(recordings[fmt]))
    read, not_needed = FORMATS[fmt]
    assert set(read) <= modules
    assert _under(modules, (*NOT_NEEDED, *not_needed)) == []
    stores = sorted(name for name in modules if name.startswith("rosbags.typesys.stores.ros"))
    assert stores == []  # no distro store: ROS 2 Humble's alone takes longer to build than the rest of `info`


def _help(parser_argv: list[str] | None, argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    """What ``tfrec ARGV`` prints: through main (``parser_argv`` None: only the subcommand's parser is built), or
    with the whole parser."""
    if parser_argv is None:
        assert main(argv) == 0
    else:
        with pytest.raises(SystemExit) as done:
            _build_parser(parser_argv).parse_args(argv)
        assert done.value.code == 0
    return capsys.readouterr().out


@pytest.mark.parametrize("argv", [["--help"], *([command, "--help"] for command in COMMANDS)], ids=" ".join)
def test_help_is_the_whole_parsers(argv: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    whole = _help([], argv, capsys)
    assert whole.startswith("usage: tfrec")
    assert _help(None, argv, capsys) == whole


def test_every_subcommand_is_listed() -> None:
    """COMMANDS (what `tfrec --help` lists, and what a parser is built for) names every module that adds one."""
    package = Path(_main.__file__).parent
    adding = {f"tfrec.cli.{file.stem}" for file in package.glob("_*.py") if "def add_parser(" in file.read_text()}
    assert {_command_module(command).__name__ for command in COMMANDS} == adding
    listed = _build_parser([]).format_help()
    assert [command for command in COMMANDS if f"\n    {command} " in listed] == list(COMMANDS)


def test_the_layouts_known_without_a_store_are_rosbags() -> None:
    """The definitions, md5sums and type hashes tfrec knows by heart are those rosbags' stores give."""
    store = typestore()
    for msgtype, text in ROS2_DEFINITIONS.items():
        assert store.generate_msgdef(msgtype, ros_version=2)[0] == text == message_definition(msgtype)[0]
    assert set(ROS_LAYOUTS) == set(INTERPRETED.values()) == set(ROS2_DEFINITIONS)
    for msgtype, (md5sum, rihs01) in ROS_LAYOUTS.items():
        assert ros1_message_definition(msgtype)[1] == md5sum
        assert store.hash_rihs01(msgtype) == rihs01


def test_a_definition_known_by_heart_is_judged_as_when_parsed() -> None:
    """tfrec's own ros2msg text is taken without parsing: the verdict is the one parsing gives (a comment added
    makes the text another, parsed and compared field by field) — ROS 2's layout, and not ROS 1's (whose Header
    has a seq)."""
    for msgtype, text in ROS2_DEFINITIONS.items():
        for ros1 in (False, True):
            known = foreign_layout(msgtype, ros1=ros1, definition=text, definition_encoding="ros2msg")
            parsed = foreign_layout(msgtype, ros1=ros1, definition=text + "# a comment\n", definition_encoding="ros2msg")
            assert known == parsed, (msgtype, ros1)
            assert (known is None) == (not ros1 or msgtype == "std_msgs/msg/String")


@settings(max_examples=200, deadline=None)
@given(name=st.one_of(st.sampled_from(["std_msgs/String", "tf/tfMessage", "pkg/msg/Type", "pkg/action/Type", "a/b/c",
                                       "Type", "", "/", "pkg/", "/pkg/Type", "a//b", "./x", "pkg/msg/"]),
                      st.text(alphabet="ab/._msgction", max_size=12)))
def test_ros1_type_names_are_normalized_as_rosbags_normalizes_them(name: str) -> None:
    from rosbags.typesys.msg import normalize_msgtype

    assert ros2_msgtype(name) == normalize_msgtype(name)


def test_the_qos_texts_known_without_pyyaml_are_pyyamls() -> None:
    """The QoS texts tfrec writes are read without PyYAML: what it would dump and load."""
    from tfrec._yaml import load_yaml, yaml_dump

    assert len(_KNOWN_QOS) == 2
    for text, profiles in _KNOWN_QOS.items():
        assert yaml_dump(profiles).rstrip("\n") == text
        assert load_yaml(text, where="qos") == profiles == _parsed_qos(text)
        assert qos_yaml(profiles) == text
    assert qos_durability(qos_yaml([QOS_LATCHED])) == "transient_local"
    assert qos_durability(qos_yaml([QOS_VOLATILE])) == "volatile"


@settings(max_examples=100, deadline=None)
@given(values=st.lists(st.integers(0, 2**32 - 1), max_size=50))
def test_distinct_is_np_unique(values: list[int]) -> None:
    array = np.array(values, dtype=np.int64)
    assert distinct(array) == np.unique(array).tolist()


_THREADS = """
import contextlib, io, os, sys
from tfrec.cli import main
with contextlib.redirect_stdout(io.StringIO()):
    code = main(["info", sys.argv[1]])
print(code, len(os.listdir("/proc/self/task")), os.environ.get("OPENBLAS_NUM_THREADS"))
"""


@pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="counts the process's threads in /proc")
def test_the_command_line_starts_openblas_with_one_thread(marm_mcap: Path) -> None:
    """numpy's OpenBLAS starts a thread per core when it loads, which tfrec never uses (no matrix past 4×4): the
    command line asks for one, unless the user set OPENBLAS_NUM_THREADS."""
    env = {name: value for name, value in os.environ.items() if name != "OPENBLAS_NUM_THREADS"}
    done = subprocess.run([sys.executable, "-c", _THREADS, str(marm_mcap)], capture_output=True, text=True,
                          check=True, env=env, preexec_fn=_cpu_limit)
    assert done.stdout.split() == ["0", "1", "1"]
    if (os.cpu_count() or 1) >= 2:
        done = subprocess.run([sys.executable, "-c", _THREADS, str(marm_mcap)], capture_output=True, text=True,
                              check=True, env={**env, "OPENBLAS_NUM_THREADS": "2"}, preexec_fn=_cpu_limit)
        assert done.stdout.split() == ["0", "2", "2"]  # the user's choice: OpenBLAS's second thread runs
