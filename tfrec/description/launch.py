"""Launch files as robot descriptions: what ``roslaunch simple_cube launch.launch`` would load.

:func:`read_launch` reads a ROS 1 roslaunch XML file, or a ROS 2 XML or YAML launch file, with
the launch system's own rules for arguments, substitutions, groups, includes and conditions, and
returns the robot it loads (:class:`LaunchRobot`): the xacro run, URDF file or inline URDF of its
``robot_description`` parameter, and the parameters it gives joint_state_publisher and
robot_state_publisher. Nothing in a launch file is run: commands other than xacro (or ``cat``)
are refused, ``$(eval)`` is evaluated only in a small Python-free subset, and a Python launch
file (``.launch.py``) is refused with the description file it names, when it can be found.

XML is read with DOCTYPE and entity declarations refused, files are bounded in size, and
includes in depth, count and cycles.
"""

from __future__ import annotations

import os
import re
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from tfrec.description._launch_common import (
    Candidate,
    DeferredValues,
    DescriptionKind,
    DescriptionSource,
    LaunchModel,
    Node,
    Param,
    YamlLoader,
    YamlText,
    boolean,
    flatten,
    load_yaml_text,
    number,
    positive_number,
    subtree,
    text_value,
)
from tfrec.description._launch_files import (
    Element,
    decode,
    parse_xml,
    read_bounded,
    static_arg_names,
    yaml_to_element,
)
from tfrec.description._launch_ros1 import Ros1Reader
from tfrec.description._launch_ros2 import Ros2Reader
from tfrec.description.packages import PackageFinder
from tfrec.errors import DescriptionError, TfrecWarning, display_path, one_line, suggest

__all__ = ["DescriptionKind", "DescriptionSource", "LaunchRobot", "NodeParams", "is_launch_file", "read_launch"]

_LAUNCH_SUFFIXES = (".launch", ".launch.xml", ".launch.py", ".launch.yaml", ".launch.yml")


@dataclass(frozen=True, slots=True)
class NodeParams:
    """What the launch file sets for the nodes tfrec stands in for; None where it sets nothing.

    Attributes:
        jsp_rate_hz: joint_state_publisher's ``rate``.
        jsp_zeros: joint_state_publisher's ``zeros`` (joint name → initial position).
        use_gui: joint_state_publisher's ``use_gui`` (True when joint_state_publisher_gui is started).
        publish_frequency_hz: robot_state_publisher's ``publish_frequency``.
        frame_prefix: prepended to every frame name, ROS 2 style: robot_state_publisher's
            ``frame_prefix`` (ROS 2) as given, or its ``tf_prefix`` (ROS 1) with the ``/`` that
            ROS 1 puts between prefix and frame (``tf_prefix="r1"`` → ``"r1/"``).
    """

    jsp_rate_hz: float | None = None
    jsp_zeros: Mapping[str, float] | None = None
    use_gui: bool | None = None
    publish_frequency_hz: float | None = None
    frame_prefix: str | None = None


@dataclass(frozen=True, slots=True)
class LaunchRobot:
    """The robot a launch file loads.

    Attributes:
        launch_file: the launch file given.
        description: where ``robot_description`` comes from (a xacro run with its arguments, a URDF
            file, or inline URDF text). File paths are as the launch file's substitutions made them.
        namespace: ROS namespace of the robot (``"/"``, ``"/r1"``).
        defined_at: ``file:line`` of the ``robot_description`` parameter.
        node_params: parameters of its joint_state_publisher and robot_state_publisher.
        launch_args: the launch file's arguments and their values in this launch.
        ros_version: 1 (roslaunch XML) or 2 (ROS 2 XML or YAML launch).
        files: every launch file read (the one given, then its includes).
    """

    launch_file: Path
    description: DescriptionSource
    namespace: str = "/"
    defined_at: str = ""
    node_params: NodeParams = field(default_factory=NodeParams)
    launch_args: Mapping[str, str] = field(default_factory=dict)
    ros_version: int = 1
    files: tuple[Path, ...] = ()

    @property
    def description_file(self) -> Path | None:
        """The xacro or URDF file to load (None for inline URDF text)."""
        return self.description.file

    @property
    def xacro_args(self) -> Mapping[str, str]:
        """The ``name:=value`` arguments of the xacro run (empty for URDF)."""
        return self.description.xacro_args


def is_launch_file(path: str | os.PathLike[str]) -> bool:
    """Whether path names a launch file (by its name, or for ``.xml``/``.py``/``.yaml`` by a look inside)."""
    file = Path(path)
    name = file.name.lower()
    if name.endswith(_LAUNCH_SUFFIXES):
        return True
    patterns = {".xml": rb"<launch[\s>/]", ".py": rb"def generate_launch_description\b",
                ".yaml": rb"(?m)^launch\s*:", ".yml": rb"(?m)^launch\s*:"}
    pattern = patterns.get(file.suffix.lower())
    if pattern is None or not file.is_file():
        return False
    try:
        with file.open("rb") as stream:
            head = stream.read(64 * 1024)
    except OSError:
        return False
    return re.search(pattern, head) is not None


def read_launch(
    path: str | os.PathLike[str],
    *,
    args: Mapping[str, str] | None = None,
    finder: PackageFinder,
    yaml_loader: YamlLoader | None = None,
    environ: Mapping[str, str] | None = None,
) -> LaunchRobot:
    """The robot a launch file loads, and the node parameters it sets.

    Args:
        path: a ``.launch``/``.launch.xml``/``.xml`` (ROS 1 or ROS 2, told apart by content) or
            ``.launch.yaml`` file.
        args: launch arguments, as ``name:=value`` on the ``roslaunch``/``ros2 launch`` command line.
            One the launch file does not declare draws a warning naming the closest declared one.
        finder: resolves ``$(find pkg)`` and ``$(find-pkg-share pkg)``.
        yaml_loader: ``yaml_loader(text, source)``, used for ROS 2 YAML launch files, ``<rosparam>``,
            ``type="yaml"`` and parameter files; without it those raise.
        environ: environment for ``$(env)``/``$(optenv)`` (default ``os.environ``).

    Raises:
        DescriptionError: one line, ``file:line: message``: a Python launch file, malformed or
            refused XML, an unknown, missing or fixed argument, an undefined substitution, an
            unsupported command, an include cycle, no or several robot descriptions.
    """
    file = Path(path)
    given = dict(args or {})
    env = os.environ if environ is None else environ
    if file.name.lower().endswith(".py"):
        raise _python_hint(file, None, finder)
    data = read_bounded(file, site=None)
    deferred = DeferredValues()
    shown = display_path(file)
    if file.suffix.lower() in (".yaml", ".yml"):
        root = yaml_to_element(load_yaml_text(decode(data, file), shown, shown, yaml_loader), file)
        version = 2
    else:
        root = parse_xml(data, file)
        version = _ros_version(root, file)
    reader: Ros1Reader | Ros2Reader
    if version == 1:
        reader = Ros1Reader(finder=finder, environ=env, yaml_loader=yaml_loader, deferred=deferred)
    else:
        reader = Ros2Reader(finder=finder, environ=env, yaml_loader=yaml_loader, deferred=deferred,
                            python_hint=lambda p, at: _python_hint(p, at, finder))
    declared = static_arg_names(root)
    try:
        model = reader.read(file, root, given)
    except DescriptionError as err:
        _warn_unknown_args(file, given, declared | reader.declared, _used_statically(root) | reader.model.used_args)
        if "\n" in str(err):  # user text (a YAML value) can hold newlines; messages are one line
            raise DescriptionError(one_line(str(err))) from None
        raise
    _warn_unknown_args(file, given, declared | reader.declared, _used_statically(root) | model.used_args)
    return _assemble(file, model, yaml_loader)


# ---- reading ---------------------------------------------------------------------------------

_ROS2_TAGS = {"let", "push-ros-namespace", "push_ros_namespace", "set_parameter", "set-parameter", "executable",
              "set_env", "set-env", "unset_env", "unset-env", "node_container", "node-container", "composable_node",
              "load_composable_node", "set_remap", "set-remap", "timer"}
_ROS1_TAGS = {"rosparam", "machine", "test", "master"}
_ROS2_SUBST = re.compile(r"\$\((?:var|find-pkg-share|find-pkg-prefix|find-exec|exec-in-pkg|command|file-content)[ )]")
_ROS1_SUBST = re.compile(r"\$\((?:arg|find|optenv) ")


def _walk(root: Element) -> list[Element]:
    out, stack = [], [root]
    while stack:
        elem = stack.pop()
        out.append(elem)
        stack.extend(elem.children)
    return out


def _ros_version(root: Element, file: Path) -> int:
    """1 for roslaunch XML, 2 for ROS 2 launch XML: by the tags and substitutions the file uses."""
    ros1 = ros2 = 0
    for elem in _walk(root):
        ros2 += elem.tag in _ROS2_TAGS or (elem.tag == "node" and "exec" in elem.attrs) or (
            elem.tag == "param" and "from" in elem.attrs)
        ros1 += elem.tag in _ROS1_TAGS or (elem.tag == "node" and "type" in elem.attrs) or (
            elem.tag == "param" and any(k in elem.attrs for k in ("command", "textfile", "binfile")))
        for value in elem.attrs.values():
            ros2 += bool(_ROS2_SUBST.search(value))
            ros1 += bool(_ROS1_SUBST.search(value))
    if ros1 != ros2:
        return 1 if ros1 > ros2 else 2
    return 1 if file.name.lower().endswith(".launch") else 2


def _used_statically(root: Element) -> set[str]:
    """Names read with ``$(arg NAME)`` or ``$(var NAME)`` anywhere in the file."""
    return {m.group(1) for elem in _walk(root) for value in elem.attrs.values()
            for m in re.finditer(r"\$\((?:arg|var) +([^\s$()]+)\)", value)}


def _warn_unknown_args(file: Path, given: Mapping[str, str], declared: set[str], used: set[str]) -> None:
    for name in given:
        if name not in declared and name not in used:
            hint = suggest(name, declared) or (f" (it declares {', '.join(sorted(declared))})" if declared
                                               else " (it declares none)")
            warnings.warn(f"{display_path(file)}: launch argument '{name}' is not declared by the launch file{hint}",
                          TfrecWarning, stacklevel=3)


# ---- Python launch files ---------------------------------------------------------------------------

_PY_FILES = re.compile(r"""["']([^"'\n]{0,200}?\.(?:urdf\.xacro|xacro|urdf))["']""")
_PY_PACKAGES = re.compile(r"""(?:get_package_share_directory|get_package_share_path|FindPackageShare)\(\s*"""
                          r"""(?:package\s*=\s*)?["']([A-Za-z0-9_]+)["']""")
_MAX_WALK = 5000


def _python_hint(path: Path, site: str | None, finder: PackageFinder) -> DescriptionError:
    """The error for a Python launch file, naming the description file it loads when found."""
    prefix = f"{site}: " if site else ""
    try:
        text = decode(read_bounded(path, site=site), path)
    except DescriptionError:
        text = ""
    names = list(dict.fromkeys(_PY_FILES.findall(text)))
    packages = list(dict.fromkeys(_PY_PACKAGES.findall(text)))
    folders: list[Path] = []
    for package in packages:
        try:
            folders.append(finder.find(package))
        except DescriptionError:
            continue
    folders += [p for p in list(path.resolve().parents)[:4] if (p / "package.xml").is_file()][:1]
    found: list[Path] = []
    for name in names:
        for folder in folders:
            found += [hit for hit in _find_named(folder, Path(name).name) if hit not in found]
    if len(found) == 1:
        advice = f"pass {display_path(found[0])} instead"
    elif found:
        advice = "pass one of " + ", ".join(display_path(f) for f in found[:4]) + " instead"
    elif names:
        where_ = f" of package {', '.join(packages[:3])}" if packages else ""
        advice = f"pass the file it loads instead ({', '.join(names[:3])}{where_})"
    else:
        advice = "pass the robot's xacro or URDF file instead"
    return DescriptionError(f"{prefix}{display_path(path)}: a Python launch file is not run by tfrec; {advice}")


def _find_named(folder: Path, name: str) -> list[Path]:
    hits: list[Path] = []
    seen = 0
    for dirpath, dirnames, filenames in os.walk(folder):
        dirnames[:] = sorted(d for d in dirnames if not d.startswith(".") and d not in ("build", "install", "log"))
        seen += len(filenames) + len(dirnames)
        if name in filenames:
            hits.append(Path(dirpath) / name)
        if seen > _MAX_WALK:
            break
    return hits


# ---- the robot -------------------------------------------------------------------------------


def _assemble(file: Path, model: LaunchModel, yaml_loader: YamlLoader | None) -> LaunchRobot:
    if not model.candidates:
        raise DescriptionError(f"{display_path(file)}: the launch file sets no robot_description parameter, so "
                               "it loads no robot; pass the robot's xacro or URDF file instead")
    chosen = _choose(file, model)
    jsp = _serving(model, chosen, jsp=True)
    rsp = _serving(model, chosen, jsp=False)
    params = _Params(model, yaml_loader)
    node_params = NodeParams()
    if jsp is not None:
        rate = params.get(jsp, "rate")
        zeros = params.tree(jsp, "zeros")
        gui = params.get(jsp, "use_gui")
        node_params = NodeParams(
            jsp_rate_hz=positive_number(rate, "joint_state_publisher rate") if rate else None,
            jsp_zeros={joint: number(p, f"joint_state_publisher zeros '{joint}'") for joint, p in zeros.items()}
            if zeros is not None else None,
            use_gui=True if jsp.pkg == "joint_state_publisher_gui" else boolean(gui, "use_gui") if gui else None,
        )
    if rsp is not None:
        frequency = rsp.params.get("publish_frequency")
        prefix = params.tf_prefix(rsp) if model.ros_version == 1 else rsp.params.get("frame_prefix")
        frame_prefix = None
        if prefix is not None:
            text = params.materialize(prefix)
            frame_prefix = text_value(text) if model.ros_version == 2 else _tf_prefix(text_value(text))
        node_params = NodeParams(
            jsp_rate_hz=node_params.jsp_rate_hz, jsp_zeros=node_params.jsp_zeros, use_gui=node_params.use_gui,
            publish_frequency_hz=positive_number(params.materialize(frequency), "robot_state_publisher "
                                                 "publish_frequency") if frequency else None,
            frame_prefix=frame_prefix,
        )
    ns = chosen.ns.rstrip("/") or "/"
    return LaunchRobot(file, chosen.source, ns, chosen.at, node_params, dict(model.launch_args), model.ros_version,
                       tuple(model.files))


def _tf_prefix(value: str) -> str:
    """ROS 1 ``tf_prefix`` as a frame prefix: tf::resolve drops leading slashes and adds one after."""
    value = value.strip().strip("/")
    return f"{value}/" if value else ""


def _ros1_search(node: Node, names: Mapping[str, Candidate]) -> str | None:
    """The robot_description a ROS 1 node reads: its own, else searchParam up from its namespace."""
    own = f"{node.private_ns}robot_description"
    if own in names:
        return own
    ns = node.ns
    while True:
        if f"{ns}robot_description" in names:
            return f"{ns}robot_description"
        if ns == "/":
            return None
        ns = ns[:-1].rsplit("/", 1)[0] + "/"


def _choose(file: Path, model: LaunchModel) -> Candidate:
    by_name: dict[str, Candidate] = {}
    for candidate in model.candidates:  # a parameter set twice keeps its last value
        by_name.pop(candidate.name, None)
        by_name[candidate.name] = candidate
    pool = list(by_name.values())
    if model.ros_version == 2:
        pool = [c for c in pool if c.node is not None and model.nodes[c.node].is_rsp] or pool
    elif len(pool) > 1:
        served = {name for node in model.nodes if node.is_rsp and (name := _ros1_search(node, by_name)) is not None}
        if len(served) == 1:
            pool = [by_name[served.pop()]]
    distinct: list[Candidate] = []
    for candidate in pool:
        if not any(c.source == candidate.source and c.ns == candidate.ns for c in distinct):
            distinct.append(candidate)
    if len(distinct) > 1:
        listed = ", ".join(f"{c.name} at {c.at}" for c in distinct[:4])
        raise DescriptionError(f"{display_path(file)}: the launch file loads {len(distinct)} robot descriptions "
                               f"({listed}); tfrec records one robot: pass its xacro or URDF file instead")
    return distinct[0]


def _serving(model: LaunchModel, chosen: Candidate, *, jsp: bool) -> Node | None:
    names = {c.name: c for c in model.candidates}
    nodes: list[Node] = []
    for index, node in enumerate(model.nodes):
        if not (node.is_jsp if jsp else node.is_rsp):
            continue
        if model.ros_version == 1:
            serves = _ros1_search(node, names) == chosen.name
        else:
            own = [c for c in model.candidates if c.node == index]
            serves = any(c.name == chosen.name for c in own) if own else node.ns == chosen.ns
        if serves:
            nodes.append(node)
    if len(nodes) > 1:
        kind = "joint_state_publisher" if jsp else "robot_state_publisher"
        warnings.warn(f"{nodes[1].at}: a second {kind} for the robot; its parameters are ignored (the first one's, "
                      f"at {nodes[0].at}, are used)", TfrecWarning, stacklevel=4)
    return nodes[0] if nodes else None


class _Params:
    """Parameter look-ups as the nodes do them (ROS 1: private, then the node's namespace)."""

    def __init__(self, model: LaunchModel, yaml_loader: YamlLoader | None) -> None:
        self.model = model
        self.yaml_loader = yaml_loader
        self.sep = "/" if model.ros_version == 1 else "."

    def materialize(self, param: Param) -> Param:
        if isinstance(param.value, YamlText):
            return Param(load_yaml_text(param.value.text, param.at, param.at, self.yaml_loader), param.at)
        return param

    def get(self, node: Node, key: str) -> Param | None:
        param = node.params.get(key)
        if param is None and self.model.ros_version == 1:
            param = self.model.params.get(node.ns + key)
        return self.materialize(param) if param is not None else None

    def tree(self, node: Node, key: str) -> dict[str, Param] | None:
        found = self._tree(node.params, key)
        if found is None and self.model.ros_version == 1:
            found = self._tree(self.model.params, node.ns + key)
        return found

    def _tree(self, params: Mapping[str, Param], key: str) -> dict[str, Param] | None:
        leaves = subtree(params, key + self.sep)
        whole = params.get(key)
        if whole is None:
            return leaves or None
        whole = self.materialize(whole)
        if isinstance(whole.value, dict):
            flat: dict[str, Param] = {}
            flatten("", whole.value, self.sep, flat, whole.at)
            return {**flat, **leaves}
        if whole.value in (None, "", {}):
            return leaves
        raise DescriptionError(f"{whole.at}: {key} is {whole.value!r}, not a mapping of joint names to positions")

    def tf_prefix(self, node: Node) -> Param | None:
        """ROS 1 robot_state_publisher's ``tf_prefix``: searchParam from its private namespace up."""
        if "tf_prefix" in node.params:
            return node.params["tf_prefix"]
        ns = node.ns
        while True:
            if f"{ns}tf_prefix" in self.model.params:
                return self.model.params[f"{ns}tf_prefix"]
            if ns == "/":
                return None
            ns = ns[:-1].rsplit("/", 1)[0] + "/"

