"""MuJoCo models for the tests: hand-written MJCF for each feature tfrec maps, and gymnasium's assets. No mujoco import
here (the ROS tier takes the models without needing the mjcf extra to collect)."""

from __future__ import annotations

from importlib.util import find_spec
from pathlib import Path


def _gym_assets() -> list[Path]:
    spec = find_spec("gymnasium")
    if spec is None or not spec.submodule_search_locations:
        return []
    folder = Path(next(iter(spec.submodule_search_locations))) / "envs" / "mujoco" / "assets"
    return sorted(folder.glob("*.xml"))


GYM = _gym_assets()


def _dm_control_suite() -> list[Path]:
    """dm_control's suite models (when installed: it pins its own mujoco, so the test extra does not install it)."""
    spec = find_spec("dm_control")
    if spec is None or not spec.submodule_search_locations:
        return []
    return sorted((Path(next(iter(spec.submodule_search_locations))) / "suite").glob("*.xml"))


DM_CONTROL = _dm_control_suite()


FEATURES = {
    # compiler angle="degree" (the default): ref, range in degrees; joint anchors off the body origin
    "ref_degrees": """<mujoco model="ref"><worldbody>
      <body name="a" pos="0 0 0.5" euler="10 20 30">
        <joint name="h1" type="hinge" axis="0 1 1" pos="0.1 0 0.2" ref="30" range="-60 90"/>
        <geom type="capsule" size="0.05 0.2" rgba="1 0 0 1"/>
        <body name="b" pos="0.3 0 0" axisangle="1 1 0 45">
          <joint name="s1" type="slide" axis="1 0 0.5" ref="0.2" range="-0.1 0.4"/>
          <geom type="box" size="0.1 0.05 0.02"/>
          <body name="c" pos="0 0.2 0" xyaxes="0 1 0 -1 0 0"><joint name="h2" pos="0 0 0.3" ref="-45" springref="20" stiffness="1"/>
            <geom type="cylinder" size="0.03 0.1"/><body name="d" zaxis="1 1 1" pos="0.1 0 0"/></body>
        </body>
      </body></worldbody></mujoco>""",
    # radians, eulerseq, defaults classes and childclass
    "radian_defaults": """<mujoco><compiler angle="radian" eulerseq="zyx" autolimits="true"/>
      <default><default class="arm"><joint axis="0 0 1" range="-1 1" ref="0.25"/><geom type="sphere" size="0.04"/>
      </default></default>
      <worldbody><body name="base" childclass="arm" euler="0.3 -1.2 2.0">
        <joint name="q1"/><geom/>
        <body name="link1" pos="0 0 0.4" euler="1.5707963267948966 0 0"><joint name="q2" range="-2 0.5"/><geom/>
          <body name="link2" pos="0.3 0 0" quat="0.707107 0 0.707107 0"><joint name="q3" class="arm"/><geom/></body>
        </body></body></worldbody></mujoco>""",
    # several joints in one body, anchors, unlimited slide, an unnamed body and joint
    "multi_joint": """<mujoco><worldbody><body name="carriage" pos="1 2 3">
        <joint name="x" type="slide" axis="1 0 0"/><joint name="y" type="slide" axis="0 1 0" range="-1 1"/>
        <joint name="yaw" axis="0 0 1" pos="0.2 0.1 0"/><joint name="pitch" axis="0 1 0" pos="0 0 0.3" ref="15"/>
        <geom type="box" size="0.2 0.2 0.05"/>
        <body pos="0.5 0 0"><joint axis="1 0 0" pos="0 0.1 0"/><geom type="sphere" size="0.05"/></body>
      </body></worldbody></mujoco>""",
    # a free base (held at its initial pose) with a ball joint (limited and not)
    "ball_free": """<mujoco><worldbody><body name="torso" pos="0 0 1.2" quat="0.9 0.1 0.2 0.3"><freejoint name="root"/>
        <geom type="sphere" size="0.1"/>
        <body name="upper" pos="0 0.2 0"><joint name="shoulder" type="ball" pos="0 0 0.05" range="0 80"/>
          <geom type="capsule" fromto="0 0 0 0 0 -0.3" size="0.04"/>
          <body name="lower" pos="0 0 -0.3"><joint name="wrist" type="ball"/><geom type="sphere" size="0.03"/></body>
        </body></body></worldbody></mujoco>""",
    # a hand: fingers coupled by joint equalities (linear polycoef, with refs), one nonlinear left free
    "equality_hand": """<mujoco><worldbody><body name="palm">
        <body name="f1" pos="0.02 0 0.1"><joint name="f1a" range="0 90" ref="5"/><geom type="box" size="0.01 0.01 0.02"/>
          <body name="f1b" pos="0 0 0.04"><joint name="f1b" range="0 120" ref="-10"/><geom size="0.01"/>
            <body name="f1c" pos="0 0 0.03"><joint name="f1c" range="0 90"/><geom size="0.01"/></body></body></body>
        <body name="f2" pos="-0.02 0 0.1"><joint name="f2a" type="slide" axis="0 0 1" range="0 0.05"/><geom size="0.01"/></body>
      </body></worldbody>
      <equality><joint joint1="f1b" joint2="f1a" polycoef="0.1 1.3 0 0 0"/>
        <joint joint1="f1c" joint2="f1b" polycoef="0 0.5 0 0 0"/>
        <joint joint1="f2a" joint2="f1a" polycoef="0.01 0.02 0 0 0"/></equality></mujoco>""",
    # <frame> elements, and a body welded to the world
    "frames": """<mujoco><worldbody><frame pos="0 0 1" euler="0 90 0"><body name="mount" pos="0.1 0 0">
        <frame quat="0 1 0 0"><body name="arm"><joint name="j" axis="0 1 0" range="-90 90"/><geom size="0.1"/></body></frame>
      </body></frame></worldbody></mujoco>""",
}


def write_features(folder: Path) -> dict[str, Path]:
    paths = {}
    for name, text in FEATURES.items():
        paths[name] = folder / f"{name}.xml"
        paths[name].write_text(text, encoding="utf-8")
    return paths


def write_included(folder: Path) -> Path:
    (folder / "parts").mkdir()
    (folder / "parts" / "arm.xml").write_text(
        '<mujoco><body name="arm" pos="0 0 0.2"><joint name="elbow" range="-90 90" ref="10"/>'
        '<geom type="box" size="0.1 0.02 0.02"/></body></mujoco>', encoding="utf-8")
    (folder / "parts" / "defaults.xml").write_text(
        '<mujoco><default><joint axis="0 1 0"/></default></mujoco>', encoding="utf-8")
    main_file = folder / "included.xml"
    main_file.write_text('<mujoco><include file="parts/defaults.xml"/><worldbody><body name="base">'
                         '<joint name="shoulder"/><geom size="0.1"/><include file="parts/arm.xml"/></body></worldbody></mujoco>',
                         encoding="utf-8")
    return main_file
