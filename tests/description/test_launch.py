"""Launch files as robot descriptions: the course's two launch files in a catkin workspace, ROS 1
and ROS 2 semantics, and one test per error message."""

from __future__ import annotations

import textwrap
from pathlib import Path
from typing import Any

import pytest
import yaml

from tests.conftest import ROBOTS
from tfrec.description import load_description
from tfrec.description.launch import DescriptionKind, LaunchRobot, is_launch_file, read_launch
from tfrec.description.packages import PackageFinder
from tfrec.errors import DescriptionError

SIMPLE_CUBE_XACRO = """\
<?xml version="1.0"?>
<robot name="simple_cube" xmlns:xacro="http://www.ros.org/wiki/xacro">

<xacro:include filename="$(find simple_cube)/urdf/parameters.xacro"/>
  <link name="base_link">
    <visual>
      <geometry>
        <box size="${size} ${size} ${size}"/>
      </geometry>
      <origin rpy = "${roll} ${pitch} ${yaw}" xyz = "${x} ${y} ${z}" />
      <material name="red"/>
    </visual>
    <collision>
      <geometry>
        <box size="${size} ${size} ${size}"/>
      </geometry>
    </collision>
    <inertial>
      <mass value="${mass}"/>
      <inertia ixx="0.01" ixy="0.0" ixz="0.0" iyy="0.01" iyz="0.0" izz="0.01"/>
    </inertial>
  </link>

</robot>
"""

PARAMETERS_XACRO = """\
<?xml version="1.0"?>
<robot xmlns:xacro="http://www.ros.org/wiki/xacro">
<xacro:property name="size" value="0.2"/>
<xacro:property name="mass" value="1.0"/>
<xacro:property name="x" value="1.0"/>
<xacro:property name="y" value="0.5"/>
<xacro:property name="z" value="0.0"/>
<xacro:property name="roll" value="0.0"/>
<xacro:property name="pitch" value="0.0"/>
<xacro:property name="yaw" value="0.0"/>
</robot>
"""

# the course slide, as typed by a student (the rviz config does not exist: roslaunch would not mind)
SIMPLE_CUBE_LAUNCH = """\
<?xml version="1.0"?>
<launch>
<param name="robot_description" command="$(find  xacro)/xacro '$(find simple_cube)/urdf/simple_cube.xacro'"/>

<node name="robot_state_publisher"
      pkg="robot_state_publisher"
      type="robot_state_publisher"
      output="screen">
</node>
<node name="rviz" pkg="rviz" type="rviz" args="-d $(find simple_cube)/config/rviz.rviz" />

</launch>
"""

VIEW_MARM_LAUNCH = """\
<launch>
    <arg name="model" />

    <!-- load the robot description -->
    <param name="robot_description" command="$(find xacro)/xacro --inorder $(find marm_description)/urdf/marm.xacro" />

    <!-- show the GUI sliders -->
    <param name="use_gui" value="true"/>

    <!-- joint_state_publisher publishes the joint states -->
    <node name="joint_state_publisher" pkg="joint_state_publisher" type="joint_state_publisher" />

    <!-- robot_state_publisher publishes tf -->
    <node name="robot_state_publisher" pkg="robot_state_publisher" type="state_publisher" />

    <!-- rviz -->
    <node name="rviz" pkg="rviz" type="rviz" args="-d $(find marm_description)/urdf.rviz" required="true" />
</launch>
"""

CUBE_WITH_ARGS = """\
<?xml version="1.0"?>
<robot name="cube" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:arg name="size" default="0.2"/>
  <xacro:arg name="name" default="base_link"/>
  <link name="$(arg name)">
    <visual><geometry><box size="$(arg size) $(arg size) $(arg size)"/></geometry></visual>
  </link>
</robot>
"""


def write(path: Path, text: str) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(textwrap.dedent(text), encoding="utf-8")
    return path


def package(src: Path, name: str) -> Path:
    write(src / name / "package.xml", f"""\
        <?xml version="1.0"?>
        <package format="2">
          <name>{name}</name><version>0.1.0</version><description>{name}</description>
          <maintainer email="student@example.com">student</maintainer><license>BSD</license>
        </package>
        """)
    return src / name


@pytest.fixture
def ws(tmp_path: Path) -> Path:
    """A catkin workspace ``ws/src`` with the course's simple_cube and marm_description packages."""
    src = tmp_path / "ws" / "src"
    cube = package(src, "simple_cube")
    write(cube / "urdf" / "simple_cube.xacro", SIMPLE_CUBE_XACRO)
    write(cube / "urdf" / "parameters.xacro", PARAMETERS_XACRO)
    write(cube / "launch" / "launch.launch", SIMPLE_CUBE_LAUNCH)
    marm = package(src, "marm_description")
    (marm / "urdf").mkdir()
    (marm / "urdf" / "marm.xacro").write_bytes((ROBOTS / "marm.xacro").read_bytes())
    write(marm / "launch" / "view_marm.launch", VIEW_MARM_LAUNCH)
    robot = package(src, "cube_robot")
    write(robot / "urdf" / "cube.urdf.xacro", CUBE_WITH_ARGS)
    return tmp_path / "ws"


def read(path: Path, ws: Path, *, args: dict[str, str] | None = None, environ: dict[str, str] | None = None,
         yaml_loader: Any = None) -> LaunchRobot:
    return read_launch(path, args=args or {}, finder=PackageFinder([ws / "src"]), environ=environ or {},
                       yaml_loader=yaml_loader)


def yaml_loader(text: str, source: str) -> Any:
    return yaml.safe_load(text)


def launch(ws: Path, text: str, name: str = "test.launch", pkg: str = "cube_robot") -> Path:
    return write(ws / "src" / pkg / "launch" / name, text)


# ---- the course's launch files -----------------------------------------------------------------


def test_simple_cube_launch(ws: Path) -> None:
    src = ws / "src"
    robot = read(src / "simple_cube" / "launch" / "launch.launch", ws)
    assert robot.ros_version == 1
    assert robot.description.kind is DescriptionKind.XACRO
    assert robot.description_file == src / "simple_cube" / "urdf" / "simple_cube.xacro"
    assert robot.xacro_args == {}
    assert robot.namespace == "/"
    assert robot.defined_at.endswith("launch.launch:3")
    assert robot.node_params.publish_frequency_hz is None and robot.node_params.jsp_rate_hz is None
    with pytest.warns(UserWarning, match="uses material 'red', which is not defined"):  # as on the slide
        loaded = load_description(robot.description_file, args=robot.xacro_args, package_paths=[src])
    with pytest.warns(UserWarning, match="uses material 'red', which is not defined"):
        direct = load_description(src / "simple_cube" / "urdf" / "simple_cube.xacro", package_paths=[src])
    assert loaded == direct
    assert loaded.name == "simple_cube" and [link.name for link in loaded.links] == ["base_link"]


def test_view_marm_launch(ws: Path) -> None:
    src = ws / "src"
    robot = read(src / "marm_description" / "launch" / "view_marm.launch", ws, args={"model": "ignored"})
    assert robot.description.kind is DescriptionKind.XACRO
    assert robot.description_file == src / "marm_description" / "urdf" / "marm.xacro"
    assert robot.description.xacro_flags == ("--inorder",)
    assert robot.xacro_args == {}
    assert robot.node_params.use_gui is True  # the global use_gui old joint_state_publisher reads
    assert robot.launch_args == {"model": "ignored"}
    loaded = load_description(robot.description_file, args=robot.xacro_args, package_paths=[src])
    assert loaded == load_description(ROBOTS / "marm.xacro")


def test_view_marm_without_model_arg(ws: Path) -> None:
    # roslaunch asks for an arg without default only when $(arg) reads it: view_marm.launch never does
    robot = read(ws / "src" / "marm_description" / "launch" / "view_marm.launch", ws)
    assert robot.launch_args == {}


def test_state_publisher_params(ws: Path) -> None:
    path = launch(ws, """\
        <launch>
          <param name="robot_description" command="$(find xacro)/xacro.py $(find cube_robot)/urdf/cube.urdf.xacro"/>
          <param name="tf_prefix" value="left"/>
          <node name="jsp" pkg="joint_state_publisher" type="joint_state_publisher">
            <param name="rate" value="50"/>
            <param name="use_gui" value="false"/>
            <rosparam param="zeros">{joint1: 0.5, joint2: -1}</rosparam>
          </node>
          <node name="rsp" pkg="robot_state_publisher" type="state_publisher">
            <param name="publish_frequency" type="double" value="30"/>
          </node>
        </launch>
        """)
    robot = read(path, ws, yaml_loader=yaml_loader)
    params = robot.node_params
    assert params.jsp_rate_hz == 50.0
    assert params.jsp_zeros == {"joint1": 0.5, "joint2": -1.0}
    assert params.use_gui is False
    assert params.publish_frequency_hz == 30.0
    assert params.frame_prefix == "left/"  # tf_prefix found by searchParam, with ROS 1's '/'


def test_rosparam_needs_a_yaml_loader(ws: Path) -> None:
    path = launch(ws, """\
        <launch>
          <param name="robot_description" command="xacro $(find cube_robot)/urdf/cube.urdf.xacro"/>
          <node name="jsp" pkg="joint_state_publisher" type="joint_state_publisher">
            <rosparam param="zeros">{joint1: 0.5}</rosparam>
          </node>
        </launch>
        """)
    with pytest.raises(DescriptionError, match=r"test\.launch:4: reading YAML .* needs a YAML loader"):
        read(path, ws)


def test_gui_node_and_private_tilde_params(ws: Path) -> None:
    path = launch(ws, """\
        <launch>
          <param name="robot_description" command="xacro $(find cube_robot)/urdf/cube.urdf.xacro"/>
          <param name="~rate" value="20"/>
          <node name="jsp_gui" pkg="joint_state_publisher_gui" type="joint_state_publisher_gui"/>
        </launch>
        """)
    robot = read(path, ws)
    assert robot.node_params.use_gui is True
    assert robot.node_params.jsp_rate_hz == 20.0


# ---- ROS 1 arguments, substitutions, conditions, includes ------------------------------------------

ARGS_LAUNCH = """\
<launch>
  <arg name="size" default="0.5"/>
  <arg name="link" value="body"/>
  <arg name="gui" default="false"/>
  <param name="robot_description"
         command="$(find xacro)/xacro '$(find cube_robot)/urdf/cube.urdf.xacro' size:=$(arg size) name:=$(arg link)"/>
  <node if="$(arg gui)" name="jsp" pkg="joint_state_publisher_gui" type="joint_state_publisher_gui"/>
  <node unless="$(arg gui)" name="jsp" pkg="joint_state_publisher" type="joint_state_publisher"/>
</launch>
"""


def test_args_defaults_and_command_line(ws: Path) -> None:
    path = launch(ws, ARGS_LAUNCH)
    robot = read(path, ws)
    assert robot.xacro_args == {"size": "0.5", "name": "body"}
    assert robot.node_params.use_gui is None
    assert robot.launch_args == {"size": "0.5", "link": "body", "gui": "false"}
    robot = read(path, ws, args={"size": "0.3", "gui": "True"})
    assert robot.xacro_args == {"size": "0.3", "name": "body"}
    assert robot.node_params.use_gui is True
    loaded = load_description(robot.description_file, args=robot.xacro_args, package_paths=[ws / "src"])
    assert [link.name for link in loaded.links] == ["body"]


def test_fixed_arg_cannot_be_set(ws: Path) -> None:
    with pytest.raises(DescriptionError, match=r"test\.launch:3: arg 'link' has a fixed value= and cannot be set "
                                               r"by the command line"):
        read(launch(ws, ARGS_LAUNCH), ws, args={"link": "other"})


def test_missing_required_arg(ws: Path) -> None:
    path = launch(ws, """\
        <launch>
          <arg name="model"/>
          <param name="robot_description" command="$(find xacro)/xacro $(arg model)"/>
        </launch>
        """)
    with pytest.raises(DescriptionError, match=r"test\.launch:3: arg 'model' is required: pass model:=VALUE"):
        read(path, ws)
    # urdf_tutorial's way: the value holds $(find), resolved after $(arg) as roslaunch does
    robot = read(path, ws, args={"model": "$(find cube_robot)/urdf/cube.urdf.xacro"})
    assert robot.description_file == ws / "src" / "cube_robot" / "urdf" / "cube.urdf.xacro"


def test_unknown_arg_warns_with_suggestion(ws: Path) -> None:
    path = launch(ws, ARGS_LAUNCH)
    with pytest.warns(UserWarning, match=r"launch argument 'sise' is not declared by the launch file "
                                         r"\(did you mean 'size'\?\)"):
        robot = read(path, ws, args={"sise": "0.3"})
    assert robot.xacro_args["size"] == "0.5"


def test_unknown_arg_warns_before_the_error_it_causes(ws: Path) -> None:
    path = launch(ws, """\
        <launch>
          <arg name="model"/>
          <param name="robot_description" textfile="$(arg model)"/>
        </launch>
        """)
    with pytest.warns(UserWarning, match="did you mean 'model'"), pytest.raises(DescriptionError, match="required"):
        read(path, ws, args={"modle": "x.urdf"})


def test_undeclared_arg(ws: Path) -> None:
    path = launch(ws, """\
        <launch>
          <arg name="model" default="x"/>
          <param name="robot_description" textfile="$(arg modle)"/>
        </launch>
        """)
    with pytest.raises(DescriptionError, match=r"test\.launch:3: \$\(arg modle\): no <arg name=\"modle\"> is "
                                               r"declared \(did you mean 'model'\?\)"):
        read(path, ws)


def test_bad_condition(ws: Path) -> None:
    path = launch(ws, ARGS_LAUNCH)
    with pytest.raises(DescriptionError, match=r"test\.launch:7: if=\"\$\(arg gui\)\" is 'yes', not true, false, "
                                               r"1 or 0"):
        read(path, ws, args={"gui": "yes"})


def test_env_optenv_dirname_eval(ws: Path) -> None:
    path = launch(ws, """\
        <launch>
          <arg name="urdf" default="$(optenv CUBE_URDF cube.urdf.xacro)"/>
          <arg name="big" default="false"/>
          <param name="robot_description"
                 command="xacro $(dirname)/../urdf/$(arg urdf) size:=$(env CUBE_SIZE)"/>
          <group if="$(eval arg('big') and size == 'large')">
            <param name="robot_description" textfile="never.urdf"/>
          </group>
          <arg name="size" default="small"/>
          <node name="jsp" pkg="joint_state_publisher" type="joint_state_publisher">
            <param name="rate" value="$(eval 10 * 2 + 5)"/>
          </node>
        </launch>
        """)
    robot = read(path, ws, environ={"CUBE_SIZE": "0.4"})
    assert robot.description_file is not None and robot.description_file.resolve() == (
        ws / "src" / "cube_robot" / "urdf" / "cube.urdf.xacro")
    assert robot.xacro_args == {"size": "0.4"}
    assert robot.node_params.jsp_rate_hz == 25.0
    with pytest.raises(DescriptionError, match=r"test\.launch:4: \$\(env CUBE_SIZE\): environment variable "
                                               r"'CUBE_SIZE' is not set"):
        read(path, ws)


def test_eval_outside_the_subset_is_refused_when_needed(ws: Path) -> None:
    path = launch(ws, """\
        <launch>
          <arg name="unused" default="$(eval __import__('os').getcwd())"/>
          <arg name="list" default="$(eval [x for x in 'ab'])"/>
          <param name="robot_description" command="xacro $(find cube_robot)/urdf/cube.urdf.xacro"/>
          <node if="$(arg list)" name="jsp" pkg="joint_state_publisher" type="joint_state_publisher"/>
        </launch>
        """)
    with pytest.raises(DescriptionError, match=r"test\.launch:5: \$\(eval \[x for x in 'ab'\]\) is not supported "
                                               r"\(unsupported ListComp"):
        read(path, ws)


def test_find_of_a_missing_package_matters_only_where_used(ws: Path) -> None:
    path = launch(ws, """\
        <launch>
          <arg name="rviz_config" default="$(find rviz)/default.rviz"/>
          <arg name="urdf" default="$(find not_here)/urdf/robot.urdf"/>
          <param name="robot_description" textfile="$(arg urdf)"/>
        </launch>
        """)
    with pytest.raises(DescriptionError, match=r"test\.launch:4: \$\(find not_here\): package 'not_here' not found"):
        read(path, ws)
    robot = read(path, ws, args={"urdf": "/robots/robot.urdf"})
    assert robot.description.kind is DescriptionKind.URDF_FILE
    assert robot.description_file == Path("/robots/robot.urdf")
    assert robot.launch_args["rviz_config"] == "$(find rviz)/default.rviz"


def test_include_with_args_groups_and_namespaces(ws: Path) -> None:
    launch(ws, """\
        <launch>
          <arg name="prefix"/>
          <arg name="size" default="1"/>
          <param name="robot_description" command="xacro $(find cube_robot)/urdf/cube.urdf.xacro size:=$(arg size)"/>
          <param name="tf_prefix" value="$(arg prefix)"/>
          <node name="robot_state_publisher" pkg="robot_state_publisher" type="robot_state_publisher">
            <param name="publish_frequency" value="$(arg size)0"/>
          </node>
        </launch>
        """, name="description.launch")
    launch(ws, """\
        <launch>
          <arg name="size"/>
          <group ns="r1">
            <include file="$(find cube_robot)/launch/description.launch">
              <arg name="prefix" value="robot1"/>
              <arg name="size" value="$(arg size)"/>
            </include>
          </group>
        </launch>
        """, name="middle.launch")
    path = launch(ws, """\
        <launch>
          <include file="$(dirname)/middle.launch" pass_all_args="true">
            <arg name="size" value="2"/>
          </include>
        </launch>
        """)
    robot = read(path, ws)
    assert robot.namespace == "/r1"
    assert robot.xacro_args == {"size": "2"}
    assert robot.node_params.publish_frequency_hz == 20.0
    assert robot.node_params.frame_prefix == "robot1/"
    assert [p.name for p in robot.files] == ["test.launch", "middle.launch", "description.launch"]
    assert robot.defined_at.endswith("description.launch:4")


def test_include_missing_arg(ws: Path) -> None:
    launch(ws, """\
        <launch>
          <arg name="model"/>
          <param name="robot_description" textfile="$(arg model)"/>
        </launch>
        """, name="inner.launch")
    path = launch(ws, '<launch>\n  <include file="$(dirname)/inner.launch"/>\n</launch>\n')
    with pytest.raises(DescriptionError, match=r"inner\.launch:3: arg 'model' has no value: the <include> at "
                                               r".*test\.launch:2 does not pass it"):
        read(path, ws)


def test_include_passes_undeclared_arg(ws: Path) -> None:
    launch(ws, """\
        <launch>
          <arg name="model" default="x.urdf"/>
          <param name="robot_description" textfile="$(arg model)"/>
        </launch>
        """, name="inner.launch")
    path = launch(ws, """\
        <launch>
          <include file="$(dirname)/inner.launch">
            <arg name="modle" value="y.urdf"/>
          </include>
        </launch>
        """)
    with pytest.raises(DescriptionError, match=r"test\.launch:2: <include> passes arg 'modle', which .*inner\.launch "
                                               r"does not declare \(did you mean 'model'\?\)"):
        read(path, ws)


def test_include_cycle(ws: Path) -> None:
    launch(ws, '<launch>\n  <include file="$(dirname)/b.launch"/>\n</launch>\n', name="a.launch")
    launch(ws, '<launch>\n\n  <include file="$(find cube_robot)/launch/a.launch"/>\n</launch>\n', name="b.launch")
    with pytest.raises(DescriptionError, match=r"b\.launch:3: include cycle: .*a\.launch -> .*b\.launch -> "
                                               r".*a\.launch$"):
        read(ws / "src" / "cube_robot" / "launch" / "a.launch", ws)


def test_include_depth_is_bounded(ws: Path) -> None:
    for i in range(40):
        launch(ws, f'<launch><include file="$(dirname)/l{i + 1}.launch"/></launch>', name=f"l{i}.launch")
    with pytest.raises(DescriptionError, match="includes nested more than 32 deep; refused"):
        read(ws / "src" / "cube_robot" / "launch" / "l0.launch", ws)


def test_two_robots(ws: Path) -> None:
    path = launch(ws, """\
        <launch>
          <group ns="left">
            <param name="robot_description" command="xacro $(find cube_robot)/urdf/cube.urdf.xacro size:=1"/>
          </group>
          <group ns="right">
            <param name="robot_description" command="xacro $(find cube_robot)/urdf/cube.urdf.xacro size:=2"/>
          </group>
        </launch>
        """)
    with pytest.raises(DescriptionError, match=r"test\.launch: the launch file loads 2 robot descriptions "
                                               r"\(/left/robot_description at .*test\.launch:3, "
                                               r"/right/robot_description at .*test\.launch:6\)"):
        read(path, ws)


def test_robot_state_publisher_picks_the_robot(ws: Path) -> None:
    path = launch(ws, """\
        <launch>
          <param name="robot_description" command="xacro $(find cube_robot)/urdf/cube.urdf.xacro size:=1"/>
          <param name="robot_description_semantic" textfile="robot.srdf"/>
          <group ns="gazebo">
            <param name="robot_description" command="xacro $(find cube_robot)/urdf/cube.urdf.xacro size:=9"/>
          </group>
          <node name="rsp" pkg="robot_state_publisher" type="robot_state_publisher"/>
        </launch>
        """)
    assert read(path, ws).xacro_args == {"size": "1"}


# ---- description sources ---------------------------------------------------------------------


def test_textfile_cat_and_inline_value(ws: Path) -> None:
    urdf = write(ws / "src" / "cube_robot" / "urdf" / "cube.urdf", '<robot name="c"><link name="a"/></robot>\n')
    path = launch(ws, '<launch><param name="robot_description" textfile="$(find cube_robot)/urdf/cube.urdf"/>'
                      '</launch>')
    robot = read(path, ws)
    assert (robot.description.kind, robot.description_file) == (DescriptionKind.URDF_FILE, urdf)
    path = launch(ws, '<launch><param name="robot_description" command="cat $(find cube_robot)/urdf/cube.urdf"/>'
                      '</launch>')
    assert read(path, ws).description_file == urdf
    path = launch(ws, """<launch><param name="robot_description" value="&lt;robot name='c'/&gt;"/></launch>""")
    robot = read(path, ws)
    assert (robot.description.kind, robot.description.text) == (DescriptionKind.URDF_TEXT, "<robot name='c'/>")


def test_unsupported_command(ws: Path) -> None:
    path = launch(ws, """\
        <launch>
          <param name="robot_description" command="rosrun my_robot make_urdf.py --arm left"/>
        </launch>
        """)
    with pytest.raises(DescriptionError, match=r"test\.launch:2: robot_description runs 'rosrun my_robot make_urdf.py "
                                               r"--arm left', which is not xacro; tfrec does not run commands"):
        read(path, ws)


def test_unsupported_xacro_option(ws: Path) -> None:
    path = launch(ws, '<launch>\n<param name="robot_description" command="xacro -o /tmp/x.urdf robot.xacro"/>\n'
                      '</launch>\n')
    with pytest.raises(DescriptionError, match=r"test\.launch:2: xacro option '-o' .* is not supported"):
        read(path, ws)


def test_no_robot_description(ws: Path) -> None:
    path = launch(ws, """\
        <launch>
          <node name="rviz" pkg="rviz" type="rviz" args="-d $(find rviz)/default.rviz"/>
        </launch>
        """)
    with pytest.raises(DescriptionError, match=r"test\.launch: the launch file sets no robot_description parameter"):
        read(path, ws)


def test_python_launch_file_names_what_to_pass(ws: Path) -> None:
    path = write(ws / "src" / "marm_description" / "launch" / "display.launch.py", """\
        import os
        from ament_index_python.packages import get_package_share_directory
        from launch import LaunchDescription
        from launch_ros.actions import Node

        def generate_launch_description():
            urdf = os.path.join(get_package_share_directory('marm_description'), 'urdf', 'marm.xacro')
            return LaunchDescription([Node(package='robot_state_publisher', executable='robot_state_publisher')])
        """)
    assert is_launch_file(path)
    with pytest.raises(DescriptionError, match=r"display\.launch\.py: a Python launch file is not run by tfrec; "
                                               r"pass .*marm_description/urdf/marm\.xacro instead$"):
        read(path, ws)


# ---- refused XML ----------------------------------------------------------------------------


def test_doctype_entity_bomb_is_refused(ws: Path) -> None:
    path = launch(ws, """\
        <?xml version="1.0"?>
        <!DOCTYPE launch [
          <!ENTITY a "aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa">
          <!ENTITY b "&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;">
          <!ENTITY c "&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;">
        ]>
        <launch><param name="robot_description" value="&c;"/></launch>
        """)
    with pytest.raises(DescriptionError, match=r"test\.launch:2: <!DOCTYPE> in a launch file is refused"):
        read(path, ws)


def test_malformed_xml(ws: Path) -> None:
    path = launch(ws, '<launch>\n  <param name="robot_description" value="x">\n</launch>\n')
    with pytest.raises(DescriptionError, match=r"test\.launch:3: malformed XML: mismatched tag"):
        read(path, ws)


def test_large_file_is_refused(ws: Path) -> None:
    path = ws / "src" / "cube_robot" / "launch" / "huge.launch"
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("wb") as stream:
        stream.truncate(11 * 1024 * 1024)
    with pytest.raises(DescriptionError, match=r"huge\.launch: larger than 10 MB; refused"):
        read(path, ws)


def test_robot_file_given_as_launch_file(ws: Path) -> None:
    path = ws / "src" / "cube_robot" / "urdf" / "cube.urdf.xacro"
    with pytest.raises(DescriptionError, match=r"cube\.urdf\.xacro:2: root element is <robot>, not <launch>: it is a "
                                               "robot description"):
        read(path, ws)


# ---- ROS 2 launch files ------------------------------------------------------------------------

ROS2_XML = """\
<launch>
  <arg name="size" default="0.5" description="cube edge"/>
  <arg name="gui" default="false"/>
  <let name="xacro_file" value="$(find-pkg-share cube_robot)/urdf/cube.urdf.xacro"/>
  <node pkg="robot_state_publisher" exec="robot_state_publisher" namespace="cube">
    <param name="robot_description" value="$(command '$(find-exec xacro) $(var xacro_file) size:=$(var size)')"/>
    <param name="publish_frequency" value="40.0"/>
    <param name="frame_prefix" value="cube/"/>
  </node>
  <group>
    <push-ros-namespace namespace="cube"/>
    <node pkg="joint_state_publisher" exec="joint_state_publisher" unless="$(var gui)">
      <param name="rate" value="30"/>
      <param name="zeros">
        <param name="joint1" value="0.25"/>
      </param>
    </node>
    <node pkg="joint_state_publisher_gui" exec="joint_state_publisher_gui" if="$(var gui)"/>
  </group>
</launch>
"""


def test_ros2_xml_launch(ws: Path) -> None:
    path = launch(ws, ROS2_XML, name="cube.launch.xml")
    robot = read(path, ws)
    assert robot.ros_version == 2
    assert robot.description.kind is DescriptionKind.XACRO
    assert robot.description_file == ws / "src" / "cube_robot" / "urdf" / "cube.urdf.xacro"
    assert robot.xacro_args == {"size": "0.5"}
    assert robot.namespace == "/cube"
    params = robot.node_params
    assert (params.publish_frequency_hz, params.frame_prefix) == (40.0, "cube/")
    assert (params.jsp_rate_hz, params.jsp_zeros, params.use_gui) == (30.0, {"joint1": 0.25}, None)
    robot = read(path, ws, args={"size": "0.1", "gui": "true"})
    assert robot.xacro_args == {"size": "0.1"}
    assert robot.node_params.use_gui is True and robot.node_params.jsp_rate_hz is None
    loaded = load_description(robot.description_file, args=robot.xacro_args, package_paths=[ws / "src"])
    assert loaded.links[0].visuals[0].geometry.size == (0.1, 0.1, 0.1)  # type: ignore[union-attr]


def test_ros2_plain_xacro_command_in_a_dot_launch_file(ws: Path) -> None:
    path = launch(ws, """\
        <launch>
          <node pkg="robot_state_publisher" exec="robot_state_publisher">
            <param name="robot_description"
                   value="$(command 'xacro $(find-pkg-share cube_robot)/urdf/cube.urdf.xacro name:=$(env LINK base)')"/>
          </node>
        </launch>
        """)
    robot = read(path, ws)
    assert robot.ros_version == 2 and robot.xacro_args == {"name": "base"}


def test_ros2_required_arg(ws: Path) -> None:
    path = launch(ws, ROS2_XML.replace('<arg name="gui" default="false"/>', '<arg name="gui"/>'),
                  name="cube.launch.xml")
    with pytest.raises(DescriptionError, match=r"cube\.launch\.xml:3: launch argument 'gui' is required: "
                                               r"pass gui:=VALUE"):
        read(path, ws)


def test_ros2_unsupported_command(ws: Path) -> None:
    path = launch(ws, """\
        <launch>
          <node pkg="robot_state_publisher" exec="robot_state_publisher">
            <param name="robot_description" value="$(command 'ros2 run my_pkg urdf_gen')"/>
          </node>
        </launch>
        """, name="x.launch.xml")
    with pytest.raises(DescriptionError, match=r"x\.launch\.xml:3: robot_description runs 'ros2 run my_pkg urdf_gen', "
                                               "which is not xacro"):
        read(path, ws)


def test_ros2_yaml_launch(ws: Path) -> None:
    path = launch(ws, """\
        launch:
        - arg:
            name: size
            default: "0.5"
        - node:
            pkg: robot_state_publisher
            exec: robot_state_publisher
            param:
            - name: robot_description
              value: "$(command 'xacro $(find-pkg-share cube_robot)/urdf/cube.urdf.xacro size:=$(var size)')"
            - name: publish_frequency
              value: 15
        """, name="cube.launch.yaml")
    with pytest.raises(DescriptionError, match=r"cube\.launch\.yaml: reading YAML .* needs a YAML loader"):
        read(path, ws)
    robot = read(path, ws, args={"size": "2"}, yaml_loader=yaml_loader)
    assert robot.xacro_args == {"size": "2"}
    assert robot.node_params.publish_frequency_hz == 15.0


def test_ros2_include_of_a_python_launch_file(ws: Path) -> None:
    write(ws / "src" / "cube_robot" / "launch" / "rsp.launch.py", "def generate_launch_description():\n    pass\n")
    path = launch(ws, '<launch>\n  <include file="$(find-pkg-share cube_robot)/launch/rsp.launch.py"/>\n</launch>\n',
                  name="x.launch.xml")
    with pytest.raises(DescriptionError, match=r"x\.launch\.xml:2: .*rsp\.launch\.py: a Python launch file is not run "
                                               r"by tfrec; pass the robot's xacro or URDF file instead"):
        read(path, ws)


def test_is_launch_file(ws: Path, tmp_path: Path) -> None:
    assert is_launch_file(ws / "src" / "simple_cube" / "launch" / "launch.launch")
    assert not is_launch_file(ws / "src" / "simple_cube" / "urdf" / "simple_cube.xacro")
    xml = write(tmp_path / "bringup.xml", "<launch></launch>\n")
    assert is_launch_file(xml)
    assert not is_launch_file(write(tmp_path / "robot.xml", "<robot name='r'/>\n"))


def test_ros2_param_file_and_unscoped_group(ws: Path) -> None:
    write(ws / "src" / "cube_robot" / "config" / "rsp.yaml", """\
        /**:
          ros__parameters:
            publish_frequency: 9.0
            frame_prefix: "p/"
        """)
    path = launch(ws, """\
        <launch>
          <group scoped="false">
            <let name="file" value="$(find-pkg-share cube_robot)/urdf/cube.urdf.xacro"/>
            <push-ros-namespace namespace="r2"/>
          </group>
          <node pkg="robot_state_publisher" exec="robot_state_publisher">
            <param from="$(find-pkg-share cube_robot)/config/rsp.yaml"/>
            <param name="robot_description" value="$(command 'xacro $(var file)')"/>
          </node>
          <node pkg="joint_state_publisher" exec="joint_state_publisher" if="$(equals $(var mode) sim)">
            <param name="rate" value="$(eval '5 * 4')"/>
          </node>
        </launch>
        """, name="x.launch.xml")
    robot = read(path, ws, args={"mode": "sim"}, yaml_loader=yaml_loader)
    assert robot.namespace == "/r2"
    assert (robot.node_params.publish_frequency_hz, robot.node_params.frame_prefix) == (9.0, "p/")
    assert robot.node_params.jsp_rate_hz == 20.0
    assert read(path, ws, args={"mode": "real"}, yaml_loader=yaml_loader).node_params.jsp_rate_hz is None


def test_ros2_text_around_a_command(ws: Path) -> None:
    path = launch(ws, """\
        <launch>
          <node pkg="robot_state_publisher" exec="robot_state_publisher">
            <param name="robot_description" value="prefix $(command 'xacro x.xacro')"/>
          </node>
        </launch>
        """, name="x.launch.xml")
    with pytest.raises(DescriptionError, match=r"x\.launch\.xml:3: robot_description 'prefix \$\(command 'xacro "
                                               r"x\.xacro'\)' mixes text with \$\(command \.\.\.\)"):
        read(path, ws)


def test_rosparam_file_for_joint_state_publisher(ws: Path) -> None:
    write(ws / "src" / "cube_robot" / "config" / "jsp.yaml", "rate: 12\nzeros:\n  j1: 0.1\n")
    path = launch(ws, """\
        <launch>
          <group ns="arm">
            <param name="robot_description" command="xacro $(find cube_robot)/urdf/cube.urdf.xacro"/>
            <param name="rate" value="7"/>
            <node name="jsp" pkg="joint_state_publisher" type="joint_state_publisher">
              <rosparam command="load" file="$(find cube_robot)/config/jsp.yaml"/>
            </node>
          </group>
        </launch>
        """)
    robot = read(path, ws, yaml_loader=yaml_loader)
    assert robot.namespace == "/arm"
    assert (robot.node_params.jsp_rate_hz, robot.node_params.jsp_zeros) == (12.0, {"j1": 0.1})  # private wins


@pytest.mark.parametrize("expr, refused", [
    ("().__class__", "double underscores"),
    ("'a' * 1000000000", "unsupported operation Mult"),
    ("2 ** 100000", "unsupported operation Pow"),
    ("open('/etc/passwd').read()", "unsupported Call"),
    ("(lambda: 1)()", "unsupported Call"),
    ("[x for x in 'ab']", "unsupported ListComp"),
    ("-" * 998 + "1", "nested too deeply"),
    ("x" * 1001, "longer than 1000 characters"),
])
def test_eval_refuses_python(expr: str, refused: str) -> None:
    from tfrec.description._launch_eval import EvalRefused, safe_eval

    with pytest.raises(EvalRefused, match=refused):
        safe_eval(expr, lambda name: name, {"arg": lambda name: name})


def test_eval_subset() -> None:
    from tfrec.description._launch_eval import safe_eval

    args = {"gui": True, "robot": "ur5", "n": 3}
    assert safe_eval("gui and robot == 'ur5'", args.__getitem__, {}) is True
    assert safe_eval("not gui or n > 2", args.__getitem__, {}) is True
    assert safe_eval("'ur' in robot and robot + '_arm' == 'ur5_arm'", args.__getitem__, {}) is True
    assert safe_eval("'left' if n == 1 else 'right'", args.__getitem__, {}) == "right"
    assert safe_eval("n * 2 - 1 / 2", args.__getitem__, {}) == 5.5
