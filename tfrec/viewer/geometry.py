"""A robot's visual geometry as Rerun component columns, as RViz's RobotModel display draws it.

Boxes, cylinders and spheres become ``Boxes3D``, ``Cylinders3D`` and ``Ellipsoids3D``; mesh files
become ``Asset3D`` with the file's bytes embedded, so a recording shows the robot without the
packages at hand. STL, OBJ, PLY and GLB files go in as they are; COLLADA (``.dae``, which Rerun
does not read) and other formats trimesh reads are converted to GLB in memory, scaled by the
file's ``<unit meter>`` and ignoring its up axis, as RViz does. Meshes that bring their own
materials keep them; others get the URDF material colour (RViz's rule, too).

Every column built here is static and has one row; :mod:`tfrec.viewer.sink` sends them.
"""

from __future__ import annotations

import logging
import os
import stat
import struct
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import rerun as rr

from tfrec.description.packages import PackageFinder
from tfrec.errors import DescriptionError
from tfrec.kinematics.rotations import matrix_from_quaternion, quaternion_from_rpy
from tfrec.model import Box, Cylinder, Material, Mesh, Robot, Sphere, Visual

__all__ = [
    "MeshAsset",
    "MeshLoader",
    "axial_extent",
    "colour_archetype",
    "default_axis_length",
    "missing_meshes",
    "rgba8",
    "spoke_columns",
    "visual_columns",
    "visual_radius",
]

_NATIVE_MEDIA_TYPES = {
    ".stl": "model/stl",
    ".obj": "model/obj",
    ".ply": "application/x-ply",
    ".glb": "model/gltf-binary",
}
"""Formats Rerun's viewer reads from an embedded blob; everything else goes through trimesh."""

_GLB = "model/gltf-binary"


@dataclass(frozen=True, slots=True)
class MeshAsset:
    """A mesh file ready to embed: its bytes (converted when needed) and media type.

    Attributes:
        contents: the bytes to embed.
        media_type: ``model/stl``, ``model/obj``, ``application/x-ply`` or ``model/gltf-binary``.
        own_colours: the file brings its own materials, so the URDF colour is not applied.
        radius_m: the largest distance of the mesh from its origin, before the URDF scale
            (0 when unknown); it fits the default camera to the robot.
    """

    contents: bytes
    media_type: str
    own_colours: bool
    radius_m: float = 0.0


class MeshLoader:
    """Finds and reads the mesh files of a robot description, each file once.

    Args:
        package_paths: folders searched first for ``package://`` packages.
        source: the description file; relative mesh paths and its own package resolve from it.
    """

    def __init__(self, package_paths: Sequence[str | os.PathLike[str]] = (), *, source: str | None = None) -> None:
        self._finder = PackageFinder(package_paths, near=source)
        self._source = source
        self._cache: dict[Path, MeshAsset | str] = {}

    def load(self, uri: str) -> MeshAsset | str:
        """Read the mesh a URDF names.

        Returns:
            The asset, or what went wrong as a phrase for a warning: ``not found (<path>)``
            or ``not readable (<reason>)``.
        """
        try:
            path = self._finder.resolve_uri(uri, relative_to=self._source)
        except DescriptionError as err:
            return f"refused ({err})" if "refused" in str(err) else f"not found ({err})"
        if path not in self._cache:
            self._cache[path] = _read_mesh(path)
        return self._cache[path]


MAX_MESH_BYTES = 256 << 20
"""The largest mesh file read."""


def _read_mesh(path: Path) -> MeshAsset | str:
    """The asset for a mesh file, or why it cannot be used (see :meth:`MeshLoader.load`).

    Only a regular file of at most :data:`MAX_MESH_BYTES` is read (a FIFO or ``/dev/zero`` would be read
    forever), and nothing is embedded unless it parses as a mesh of its type: a file that is not one (a
    link to ``/etc/passwd`` named ``x.stl``) is skipped, and its content is not quoted.
    """
    try:
        info = path.stat()
    except OSError:
        return f"not found ({path})"
    if not stat.S_ISREG(info.st_mode):
        return f"not readable ({path}: not a regular file)"
    if info.st_size > MAX_MESH_BYTES:
        return f"not readable ({path}: {info.st_size:,} bytes, more than the {MAX_MESH_BYTES >> 20} MiB a mesh may have)"
    try:
        # what is opened is checked again (a FIFO put in its place would block the open without O_NONBLOCK), and
        # read for its size: read(MAX_MESH_BYTES) would allocate 256 MiB for every mesh first
        with open(os.open(path, os.O_RDONLY | os.O_NONBLOCK), "rb") as stream:
            opened = os.fstat(stream.fileno())
            if not stat.S_ISREG(opened.st_mode) or opened.st_size > MAX_MESH_BYTES:
                return f"not readable ({path}: not a regular file of at most {MAX_MESH_BYTES >> 20} MiB)"
            data = stream.read(opened.st_size + 1)
    except OSError as err:
        return f"not readable ({path}: {err.strerror or err})"
    suffix = path.suffix.lower()
    media_type = _NATIVE_MEDIA_TYPES.get(suffix)
    try:
        scene = _load_scene(path)
    except _mesh_errors() as err:
        return f"not readable ({path}: not a {suffix.lstrip('.') or 'mesh'} file trimesh can read: {type(err).__name__})"
    radius = _radius(scene)
    if media_type is not None:
        own = suffix == ".glb" or (suffix == ".ply" and _ply_has_colours(data))
        return MeshAsset(data, media_type, own, radius)
    assert scene is not None
    with _quiet_trimesh():
        glb = scene.export(file_type="glb")
    own = suffix == ".dae" and b"<library_materials" in data and b"<material " in data
    return MeshAsset(glb, _GLB, own, radius)


def _ply_has_colours(data: bytes) -> bool:
    header = data[: data.find(b"end_header")] if b"end_header" in data else b""
    return b"property uchar red" in header or b"property uchar diffuse_red" in header


@contextmanager
def _quiet_trimesh() -> Iterator[None]:
    """trimesh logs (and prints tracebacks for) missing textures; library code stays silent."""
    logger = logging.getLogger("trimesh")  # trimesh's modules log through children of this one
    level = logger.level
    logger.setLevel(logging.CRITICAL + 1)
    try:
        yield
    finally:
        logger.setLevel(level)


def _mesh_errors() -> tuple[type[BaseException], ...]:
    """What trimesh and its loaders raise on a file they cannot read."""
    errors: list[type[BaseException]] = [
        ImportError, ValueError, KeyError, IndexError, TypeError, AttributeError, NotImplementedError, OSError,
        struct.error,
    ]
    try:
        from collada.common import DaeError  # pycollada, which trimesh uses for .dae

        errors.append(DaeError)
    except ImportError:
        pass
    return tuple(errors)


def _load_scene(path: Path) -> Any:
    """The file as a trimesh Scene in metres (COLLADA's ``<unit meter>`` applied; needs pycollada).

    Raises:
        ImportError: no loader for the format (pycollada for ``.dae``); errors of :func:`_mesh_errors`.
    """
    import trimesh  # deferred: importing trimesh costs ~0.3 s

    with _quiet_trimesh():
        scene: Any = trimesh.load(os.fspath(path), force="scene")
        units = getattr(scene, "units", None)
        if units and units != "meters":
            scene = scene.scaled(trimesh.units.unit_conversion(units, "meters"))
    if scene.is_empty:
        raise ValueError("no geometry in the file")
    return scene


def _radius(scene: Any) -> float:
    corners = np.asarray(scene.bounds, dtype=np.float64)
    return float(np.max(np.linalg.norm(corners, axis=1)))


def rgba8(material: Material | None) -> int | None:
    """A material's colour as Rerun's packed 0xRRGGBBAA, or None when it has none."""
    if material is None or material.rgba is None:
        return None
    r, g, b, a = (round(min(max(c, 0.0), 1.0) * 255.0) for c in material.rgba)
    return (r << 24) | (g << 16) | (b << 8) | a


def colour_archetype(visual: Visual) -> str:
    """The archetype :func:`visual_columns` logs a visual's colour with: ``Boxes3D``, ``Cylinders3D``,
    ``Ellipsoids3D`` (``colors``) or ``Asset3D`` (``albedo_factor``)."""
    kinds = {Box: "Boxes3D", Cylinder: "Cylinders3D", Sphere: "Ellipsoids3D"}
    return kinds.get(type(visual.geometry), "Asset3D")


def visual_columns(visual: Visual, asset: MeshAsset | None, *, colour: int | None = None) -> list[Any]:
    """The static columns of one visual: its origin as ``InstancePoses3D`` and its shape.

    Args:
        visual: the URDF visual.
        asset: the mesh to embed when the geometry is a mesh (None: the origin alone).
        colour: 0xRRGGBBAA for the shape instead of its material's (a mesh's own colours too);
            0 for no colour at all.

    Returns:
        Component columns of one row each, for ``rr.send_columns`` with no index.
    """
    geometry = visual.geometry
    scale = geometry.scale if isinstance(geometry, Mesh) else (1.0, 1.0, 1.0)
    columns: list[Any] = list(
        rr.InstancePoses3D.columns(
            translations=[visual.origin.xyz],
            quaternions=[quaternion_from_rpy(visual.origin.rpy)],
            scales=[scale],
        )
    )
    own = colour is None
    if colour is None:
        colour = rgba8(visual.material)
    colours = None if not colour else [colour]
    solid = [rr.components.FillMode.Solid]
    if isinstance(geometry, Box):
        columns += rr.Boxes3D.columns(half_sizes=[np.asarray(geometry.size) / 2.0], colors=colours, fill_mode=solid)
    elif isinstance(geometry, Cylinder):
        columns += rr.Cylinders3D.columns(
            lengths=[geometry.length], radii=[geometry.radius], colors=colours, fill_mode=solid
        )
    elif isinstance(geometry, Sphere):
        columns += rr.Ellipsoids3D.columns(half_sizes=[[geometry.radius] * 3], colors=colours, fill_mode=solid)
    elif asset is not None:
        albedo = None if (asset.own_colours and own) or not colour else [colour]
        columns += rr.Asset3D.columns(blob=[asset.contents], media_type=[asset.media_type], albedo_factor=albedo)
    return columns


def visual_radius(visual: Visual, asset: MeshAsset | None = None) -> float:
    """The radius of a ball about a visual's origin that holds its shape, in metres.

    A mesh's comes from its asset (0 without one).
    """
    geometry = visual.geometry
    if isinstance(geometry, Mesh):
        return asset.radius_m * max(abs(s) for s in geometry.scale) if asset is not None else 0.0
    if isinstance(geometry, Box):
        return float(np.linalg.norm(geometry.size)) / 2.0
    if isinstance(geometry, Cylinder):
        return float(np.hypot(geometry.radius, geometry.length / 2.0))
    return geometry.radius


def default_axis_length(robot: Robot) -> float:
    """The length of the links' TF axes: a tenth of the longest chain of joint offsets from the root,
    within [2 cm, 25 cm]."""
    reach: dict[str, float] = {robot.root: 0.0}
    for joint in robot.tree_order:
        reach[joint.child] = reach.get(joint.parent, 0.0) + float(np.linalg.norm(joint.origin.xyz))
    return min(max(0.1 * max(reach.values()), 0.02), 0.25)


MESHES_LISTED = 3
"""Meshes named in :func:`missing_meshes`' one warning; the others are counted."""


def missing_meshes(missing: Mapping[tuple[str, str], str]) -> str:
    """One warning for the meshes of a robot that cannot be shown: (file, link) → why, as
    :meth:`MeshLoader.load` says it; the first few named, the others counted."""
    shown = [f"{uri}: mesh for link '{link}' {why}" for (uri, link), why in list(missing.items())[:MESHES_LISTED]]
    if len(missing) == 1:
        return f"{shown[0]}; link logged without it"
    more = f"; and {len(missing) - MESHES_LISTED} more" if len(missing) > MESHES_LISTED else ""
    return f"{len(missing)} meshes cannot be shown (their links are logged without them): {'; '.join(shown)}{more}"


SPOKE_COLOUR = 0xFFC400FF
"""A wheel's spoke: amber, seen against light and dark materials."""


def axial_extent(visual: Visual, axis: Sequence[float], asset: MeshAsset | None = None) -> float:
    """How far a visual reaches along ``axis`` (a unit vector of its link's frame) from the link's origin: where
    a wheel's faces are."""
    a = np.asarray(axis, dtype=np.float64)
    a = a / np.linalg.norm(a)
    rotation = matrix_from_quaternion(quaternion_from_rpy(visual.origin.rpy))
    local = rotation.T @ a  # the axis in the visual's frame
    offset = abs(float(np.dot(a, visual.origin.xyz)))
    geometry = visual.geometry
    if isinstance(geometry, Cylinder):
        along = abs(float(local[2]))
        half = along * geometry.length / 2.0 + np.sqrt(max(0.0, 1.0 - along * along)) * geometry.radius
    elif isinstance(geometry, Box):
        half = float(np.sum(np.abs(local) * np.asarray(geometry.size) / 2.0))
    else:
        half = visual_radius(visual, asset)
    return offset + float(half)


def spoke_columns(axis: Sequence[float], length_m: float, face_m: float) -> list[Any]:
    """Spokes on a wheel turning about ``axis`` (its joint's axis, in the wheel's frame): on each face (``face_m``
    from the centre along the axis), a line of ``length_m`` from the axis outwards, perpendicular to it, so that the
    wheel's angle shows (a round wheel turning looks still)."""
    a = np.asarray(axis, dtype=np.float64)
    a = a / np.linalg.norm(a)
    other = np.eye(3)[int(np.argmin(np.abs(a)))]  # the basis vector least along the axis
    radial = np.cross(a, other)
    radial /= np.linalg.norm(radial)
    strips = [np.stack([side * face_m * a, side * face_m * a + radial * length_m]) for side in (1.0, -1.0)]
    radius = max(length_m / 25.0, 1e-4)
    return [*rr.LineStrips3D.columns(strips=strips, colors=[SPOKE_COLOUR] * 2, radii=[radius] * 2).partition([2])]
