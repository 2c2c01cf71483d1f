"""MuJoCo models (MJCF) → a URDF of the same kinematics → :class:`~tfrec.model.Robot`.

MuJoCo compiles the model (includes, defaults classes, ``compiler angle``/``eulerseq``, ``meshdir``,
``autolimits``, frames, ``ref``): tfrec reads the compiled ``MjModel``, after
:func:`~tfrec.description._mjcf_confine.check_mjcf` has confined what it may read and bounded what it
builds. The kinematic tree is written as a URDF (the ``/robot_description`` of a recording, what
``tfrec inspect --urdf`` prints), and that URDF is loaded as any other: one model type downstream.

The mapping (docs/cli.md, "MuJoCo models"):

=================  ===========================================================================
MJCF               URDF
=================  ===========================================================================
world body         the root link ``world``; its geoms are its visuals
body               a link of the body's name (``body_<id>`` when unnamed); its frame is MuJoCo's
                   body frame (``xpos``, ``xquat``)
no joint, weld     a fixed joint ``<body>_fixed`` (published on /tf_static)
hinge              ``revolute`` (limited) or ``continuous`` (unlimited), named as in MJCF
slide              ``prismatic``; unlimited: a ±1 m range about ``ref`` (URDF needs one)
ball               three ``revolute``/``continuous`` joints ``<name>_x``, ``_y``, ``_z`` (the
                   quaternion as intrinsic x-y-z angles), limited to ±``range`` when limited
free               a fixed joint (the free joint's name) holding the body at its initial pose
joint equality     ``<mimic>`` when ``polycoef`` is linear (a0, a1; a2..a4 = 0) and joint2 given
several joints     one link per joint between the parent and the body: ``<body>_<joint>``
=================  ===========================================================================

Joint positions are MuJoCo's ``qpos`` values: a joint with ``ref`` (``qpos0``) is at its modelled pose
when its position equals ``ref``, as in MuJoCo; the URDF origin carries the offset. A joint's ``pos``
(its anchor inside the body) gives an extra link when it is not the body origin. Geoms in groups 0–2
(those MuJoCo's viewer shows) become visuals: boxes, spheres, cylinders, capsules (a cylinder and two
spheres), meshes (file, ``scale``, with MuJoCo's re-centring undone); planes, height fields and
ellipsoids are left out.
"""

from __future__ import annotations

import math
import os
import warnings
import xml.etree.ElementTree as ET
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from tfrec.description._confine import ReadRoots
from tfrec.description._mjcf_confine import MjcfLimits, check_mjcf, is_mjcf_text
from tfrec.description.packages import PackageFinder
from tfrec.description.urdf import parse_urdf
from tfrec.errors import DescriptionError, TfrecWarning, display_path, one_line
from tfrec.model import Robot

__all__ = ["ball_joint_names", "is_mjcf_file", "is_mjcf_robot", "load_mjcf", "mjcf_to_urdf"]

Matrix = NDArray[np.float64]

UNLIMITED_SLIDE_M = 1.0
"""Half the range given to an unlimited slide joint, about its ``ref``: URDF prismatic joints need limits."""

_VISIBLE_GROUPS = 3
"""Geom groups 0, 1 and 2: those MuJoCo's viewer shows by default (collision geoms usually sit in group 3)."""

_UNNAMED_MODEL = "MuJoCo Model"
"""The name MuJoCo gives a model without ``<mujoco model>``: the file's stem is taken instead (output names)."""

_DEFAULT_RGBA = (0.5, 0.5, 0.5, 1.0)
"""A geom's rgba when none is given: its material's colour then shows, as in MuJoCo's renderer."""

# mjtJoint and mjtGeom values (stable since MuJoCo 2.0)
_FREE, _BALL, _SLIDE, _HINGE = 0, 1, 2, 3
_SPHERE, _CAPSULE, _CYLINDER, _BOX, _MESH = 2, 3, 5, 6, 7
_EQ_JOINT = 2


def is_mjcf_file(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` is a ``.xml`` file whose root element is ``<mujoco>``."""
    file = Path(path)
    if file.suffix.lower() != ".xml" or not file.is_file():
        return False
    try:
        with file.open("rb") as stream:
            head = stream.read(64 * 1024)
    except OSError:
        return False
    return is_mjcf_text(head)


def is_mjcf_robot(robot: Robot) -> bool:
    """Whether a robot was loaded from a MuJoCo model (its source is an MJCF file)."""
    return robot.source is not None and is_mjcf_file(robot.source)


def ball_joint_names(name: str) -> tuple[str, str, str]:
    """The three joint names a ball joint becomes: rotations about the body's x, then y, then z axis."""
    return (f"{name}_x", f"{name}_y", f"{name}_z")


def load_mjcf(
    path: str | os.PathLike[str],
    *,
    package_paths: Sequence[str | os.PathLike[str]] = (),
    allow_paths: Sequence[str | os.PathLike[str]] = (),
    limits: MjcfLimits | None = None,
) -> Robot:
    """Load a MuJoCo model as a :class:`Robot` (see the module's docstring for the mapping).

    Args:
        path: the model's ``.xml`` file.
        package_paths: folders its includes and assets may be read from besides its own folder.
        allow_paths: more folders or files it may read (``--allow-path``).
        limits: the bounds of the model (:class:`~tfrec.description._mjcf_confine.MjcfLimits`).

    Raises:
        DescriptionError: one line naming the file: a refused include or asset, a model over the bounds,
            MuJoCo's own compile error, or the ``mujoco`` package missing.
    """
    shown = display_path(path)
    roots = ReadRoots(path, finder=PackageFinder(package_paths, near=path), package_paths=package_paths,
                      allow_paths=allow_paths)
    dirs = check_mjcf(path, roots, limits)
    model = _compile(Path(path), shown)
    mesh_dirs = [dirs[key] for key in ("meshdir", "assetdir") if key in dirs]
    text = mjcf_to_urdf(model, name=Path(path).stem, folder=Path(path).parent, mesh_dirs=mesh_dirs, where=shown)
    return parse_urdf(text, source=os.fspath(path), user_lines=False)


def _compile(path: Path, shown: str) -> Any:
    try:
        import mujoco
    except ImportError:
        raise DescriptionError(f"{shown}: a MuJoCo model needs the mujoco package: pip install "
                               "'tfrec-robotics[mjcf]'") from None
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(lambda text: None)  # dynamics warnings (inertia...): nothing kinematic
    try:
        return mujoco.MjModel.from_xml_path(os.fspath(path))
    except ValueError as err:
        raise DescriptionError(f"{shown}: MuJoCo cannot compile it: {one_line(str(err))}") from None
    finally:
        mujoco.set_mju_user_warning(previous)


# ----------------------------------------------------------------------------------------------- poses


def _translation(xyz: Sequence[float] | Matrix) -> Matrix:
    out = np.eye(4)
    out[:3, 3] = xyz
    return out


def _rotation(quat_wxyz: Sequence[float] | Matrix) -> Matrix:
    w, x, y, z = (float(v) for v in quat_wxyz)
    norm = math.sqrt(w * w + x * x + y * y + z * z)
    w, x, y, z = w / norm, x / norm, y / norm, z / norm
    out = np.eye(4)
    out[:3, :3] = [
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ]
    return out


def _axis_angle(axis: Matrix, angle: float) -> Matrix:
    half = 0.5 * angle
    return _rotation([math.cos(half), *(math.sin(half) * np.asarray(axis, dtype=np.float64))])


def _pose(pos: Sequence[float] | Matrix, quat_wxyz: Sequence[float] | Matrix) -> Matrix:
    out = _rotation(quat_wxyz)
    out[:3, 3] = pos
    return out


def _inverse(matrix: Matrix) -> Matrix:
    out = np.eye(4)
    out[:3, :3] = matrix[:3, :3].T
    out[:3, 3] = -matrix[:3, :3].T @ matrix[:3, 3]
    return out


def _rpy(matrix: Matrix) -> tuple[float, float, float]:
    """URDF roll, pitch, yaw of a rotation, exact to rounding also at pitch ±90° (MJCF's common
    ``quat="0.707107 0 0.707107 0"``): pitch and yaw first, then roll from what they leave."""
    r = matrix[:3, :3]
    pitch = math.atan2(-r[2, 0], math.hypot(r[0, 0], r[1, 0]))
    yaw = math.atan2(r[1, 0], r[0, 0])
    cy, sy, cp, sp = math.cos(yaw), math.sin(yaw), math.cos(pitch), math.sin(pitch)
    rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
    ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    rest = ry.T @ rz.T @ r
    roll = math.atan2(rest[2, 1], rest[1, 1])
    return (roll, pitch, yaw)


def _numbers(values: Sequence[float] | Matrix) -> str:
    return " ".join(repr(float(v) + 0.0) for v in values)


def _origin(parent: ET.Element, matrix: Matrix) -> None:
    ET.SubElement(parent, "origin", xyz=_numbers(matrix[:3, 3]), rpy=_numbers(_rpy(matrix)))


# ----------------------------------------------------------------------------------------------- model


@dataclass(frozen=True, slots=True)
class _Dof:
    """One URDF joint made from an MJCF joint (a ball joint makes three)."""

    name: str
    kind: str
    axis: Matrix
    anchor: Matrix
    ref: float
    limit: tuple[float, float] | None


class _Names:
    """Unique names for generated links or joints (MJCF names kept as they are)."""

    def __init__(self, taken: Sequence[str]) -> None:
        self._taken = set(taken)

    def new(self, wanted: str) -> str:
        name = wanted
        while name in self._taken:
            name += "_"
        self._taken.add(name)
        return name


def _name(model: Any, kind: Any, index: int, fallback: str) -> str:
    import mujoco

    return mujoco.mj_id2name(model, kind, index) or fallback


def mjcf_to_urdf(model: Any, *, name: str = "mujoco", folder: Path | None = None,
                 mesh_dirs: Sequence[str] = (), where: str = "<mjcf>") -> str:
    """The URDF text of a compiled ``mujoco.MjModel``'s kinematic tree and visual geoms.

    Args:
        model: a ``mujoco.MjModel``.
        name: the robot's name when the model has none (``<mujoco model>``).
        folder: the model's folder, which relative mesh files are in.
        mesh_dirs: the model's ``meshdir`` and ``assetdir`` (relative to ``folder``): MuJoCo before 4.0 keeps a
            mesh's file as written, without them.
        where: the model's file, for warnings.
    """
    import mujoco

    bodies = [_name(model, mujoco.mjtObj.mjOBJ_BODY, i, f"body_{i}") for i in range(model.nbody)]
    bodies[0] = "world"
    joints = [_name(model, mujoco.mjtObj.mjOBJ_JOINT, j, f"joint_{j}") for j in range(model.njnt)]
    links = _Names(bodies)
    joint_names = _Names([d.name for j in range(model.njnt) for d in _dofs(model, j, joints[j])])
    mimics = _mimics(model, joints, where)
    title = bytes(model.names[: bytes(model.names).find(b"\0")]).decode("utf-8", "replace")
    if title in ("", _UNNAMED_MODEL):
        title = name
    robot = ET.Element("robot", name=title)
    places = _Places(folder or Path(), tuple(mesh_dirs))
    for body in range(model.nbody):
        _link(robot, model, body, bodies[body], places)
    for body in range(1, model.nbody):
        parent = bodies[int(model.body_parentid[body])]
        _body_joints(robot, model, body, (parent, bodies[body]), joints, (links, joint_names), mimics)
    ET.indent(robot)
    return '<?xml version="1.0"?>\n' + ET.tostring(robot, encoding="unicode") + "\n"


def _dofs(model: Any, joint: int, name: str) -> list[_Dof]:
    kind = int(model.jnt_type[joint])
    adr = int(model.jnt_qposadr[joint])
    limited = bool(model.jnt_limited[joint])
    low, high = (float(v) for v in model.jnt_range[joint])
    anchor = np.array(model.jnt_pos[joint], dtype=np.float64)
    if kind == _HINGE:
        return [_Dof(name, "revolute" if limited else "continuous", np.array(model.jnt_axis[joint]), anchor,
                     float(model.qpos0[adr]), (low, high) if limited else None)]
    if kind == _SLIDE:
        ref = float(model.qpos0[adr])
        return [_Dof(name, "prismatic", np.array(model.jnt_axis[joint]), np.zeros(3), ref,
                     (low, high) if limited else (ref - UNLIMITED_SLIDE_M, ref + UNLIMITED_SLIDE_M))]
    if kind == _BALL:
        return [_Dof(part, "revolute" if limited else "continuous", axis, anchor, 0.0,
                     (-high, high) if limited else None)
                for part, axis in zip(ball_joint_names(name), np.eye(3))]
    return []  # free: the body stays at its initial pose


def _mimics(model: Any, joints: Sequence[str], where: str) -> dict[str, tuple[str, float, float]]:
    """Joint equalities whose polynomial is linear: joint1 = a1 * joint2 + (a0 + ref1 - a1 * ref2)."""
    out: dict[str, tuple[str, float, float]] = {}
    for eq in range(model.neq):
        one, two = int(model.eq_obj1id[eq]), int(model.eq_obj2id[eq])
        if int(model.eq_type[eq]) != _EQ_JOINT or not model.eq_active0[eq] or two < 0:
            continue
        if int(model.jnt_type[one]) not in (_HINGE, _SLIDE) or int(model.jnt_type[two]) not in (_HINGE, _SLIDE):
            continue
        coef = [float(c) for c in model.eq_data[eq][:5]]
        if any(coef[2:]):
            warnings.warn(f"{where}: the joint equality of '{joints[one]}' and '{joints[two]}' is not linear "
                          "(polycoef a2..a4): the two joints move independently", TfrecWarning, stacklevel=4)
            continue
        ref1 = float(model.qpos0[model.jnt_qposadr[one]])
        ref2 = float(model.qpos0[model.jnt_qposadr[two]])
        out[joints[one]] = (joints[two], coef[1], coef[0] + ref1 - coef[1] * ref2)
    return out


def _body_joints(robot: ET.Element, model: Any, body: int, ends: tuple[str, str], joints: Sequence[str],
                 names: tuple[_Names, _Names], mimics: dict[str, tuple[str, float, float]]) -> None:
    """The URDF joints from the parent link to the body: one per degree of freedom, links between them."""
    parent, child = ends
    links, joint_names = names
    first = int(model.body_jntadr[body])
    body_joints = range(first, first + int(model.body_jntnum[body]))
    pending = _pose(model.body_pos[body], model.body_quat[body])
    dofs = [dof for j in body_joints for dof in _dofs(model, j, joints[j])]
    fixed_name = next((joints[j] for j in body_joints if int(model.jnt_type[j]) == _FREE), f"{child}_fixed")
    previous = parent
    for index, dof in enumerate(dofs):
        offset = (_axis_angle(dof.axis, -dof.ref) if dof.kind != "prismatic"
                  else _translation(-dof.ref * dof.axis))
        origin = pending @ _translation(dof.anchor) @ offset
        pending = _translation(-dof.anchor)
        last = index == len(dofs) - 1
        target = child if last and not dof.anchor.any() else links.new(f"{child}_{dof.name}")
        if target != child:
            ET.SubElement(robot, "link", name=target)
        _joint(robot, dof, (previous, target), origin, mimics.get(dof.name))
        previous = target
    if previous != child:
        fixed = ET.SubElement(robot, "joint", name=joint_names.new(f"{child}_anchor" if dofs else fixed_name),
                              type="fixed")
        _origin(fixed, pending)
        ET.SubElement(fixed, "parent", link=previous)
        ET.SubElement(fixed, "child", link=child)


def _joint(robot: ET.Element, dof: _Dof, ends: tuple[str, str], origin: Matrix,
           mimic: tuple[str, float, float] | None) -> None:
    elem = ET.SubElement(robot, "joint", name=dof.name, type=dof.kind)
    _origin(elem, origin)
    ET.SubElement(elem, "parent", link=ends[0])
    ET.SubElement(elem, "child", link=ends[1])
    ET.SubElement(elem, "axis", xyz=_numbers(dof.axis))
    if dof.limit is not None:
        ET.SubElement(elem, "limit", lower=repr(dof.limit[0]), upper=repr(dof.limit[1]), effort="0", velocity="0")
    if mimic is not None:
        ET.SubElement(elem, "mimic", joint=mimic[0], multiplier=repr(mimic[1]), offset=repr(mimic[2]))


# ---------------------------------------------------------------------------------------------- visuals


def _link(robot: ET.Element, model: Any, body: int, name: str, places: _Places) -> None:
    link = ET.SubElement(robot, "link", name=name)
    first = int(model.body_geomadr[body])
    if first < 0:
        return
    for geom in range(first, first + int(model.body_geomnum[body])):
        if int(model.geom_group[geom]) >= _VISIBLE_GROUPS:
            continue
        rgba = _colour(model, geom)
        if rgba[3] <= 0:
            continue
        for index, (frame, shape) in enumerate(_shapes(model, geom, places)):
            visual = ET.SubElement(link, "visual", name=f"{name}_geom{geom}" + (f"_{index}" if index else ""))
            _origin(visual, frame)
            geometry = ET.SubElement(visual, "geometry")
            geometry.append(shape)
            material = ET.SubElement(visual, "material", name=f"{name}_geom{geom}_rgba")
            ET.SubElement(material, "color", rgba=_numbers(rgba))


def _colour(model: Any, geom: int) -> tuple[float, ...]:
    rgba = tuple(float(v) for v in model.geom_rgba[geom])
    material = int(model.geom_matid[geom])
    if material >= 0 and np.allclose(rgba, _DEFAULT_RGBA, atol=1e-6):
        return tuple(float(v) for v in model.mat_rgba[material])
    return rgba


def _shapes(model: Any, geom: int, places: _Places) -> Iterator[tuple[Matrix, ET.Element]]:
    """Each URDF shape of a geom with its pose in the body frame (a capsule gives three)."""
    frame = _pose(model.geom_pos[geom], model.geom_quat[geom])
    kind = int(model.geom_type[geom])
    size = [float(v) for v in model.geom_size[geom]]
    if kind == _SPHERE:
        yield frame, ET.Element("sphere", radius=repr(size[0]))
    elif kind == _BOX:
        yield frame, ET.Element("box", size=_numbers([2 * v for v in size]))
    elif kind in (_CYLINDER, _CAPSULE):
        yield frame, ET.Element("cylinder", radius=repr(size[0]), length=repr(2 * size[1]))
        if kind == _CAPSULE:
            for side in (1.0, -1.0):
                yield frame @ _translation([0.0, 0.0, side * size[1]]), ET.Element("sphere", radius=repr(size[0]))
    elif kind == _MESH:
        mesh = int(model.geom_dataid[geom])
        path = _mesh_path(model, mesh, places)
        if path:
            # MuJoCo moved the mesh to its inertial frame: the file's frame is the geom's times that move undone
            recentred = _pose(model.mesh_pos[mesh], model.mesh_quat[mesh])
            yield frame @ _inverse(recentred), ET.Element("mesh", filename=path,
                                                               scale=_numbers(model.mesh_scale[mesh]))


@dataclass(frozen=True, slots=True)
class _Places:
    """Where a model's relative mesh files are: its folder, and its ``meshdir``/``assetdir`` in it."""

    folder: Path
    mesh_dirs: tuple[str, ...]


def _mesh_path(model: Any, mesh: int, places: _Places) -> str:
    """The mesh's file as an absolute ``file://`` URI (a recording's /robot_description then finds it wherever the
    recording is replayed on this machine, as RViz and Foxglove read it); "" for a mesh given inline."""
    start = int(model.mesh_pathadr[mesh])
    if start < 0:
        return ""
    raw = bytes(model.paths[start:])
    path = Path(raw[: raw.find(b"\0")].decode("utf-8", "surrogateescape"))
    if not path.is_absolute():  # MuJoCo 4 keeps meshdir in the path, 3.x only the file as written
        candidates = [places.folder / path, *(places.folder / folder / path for folder in places.mesh_dirs)]
        path = next((candidate for candidate in candidates if candidate.is_file()), candidates[0])
    return Path(os.path.abspath(path)).as_uri()
