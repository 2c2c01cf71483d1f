"""JointControl: the joints clients move, within their ranges (no server needed)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tfrec.description import parse_urdf
from tfrec.errors import TrajectoryError
from tfrec.live.joints import JointControl

URDF = """<robot name='r'><link name='a'/><link name='b'/><link name='c'/><link name='d'/><link name='e'/>
<joint name='hinge' type='revolute'><parent link='a'/><child link='b'/>
  <limit lower='0.5' upper='1.5' effort='1' velocity='1'/>
  <safety_controller soft_lower_limit='0.6' soft_upper_limit='1.4' k_velocity='1'/></joint>
<joint name='wheel' type='continuous'><parent link='a'/><child link='c'/></joint>
<joint name='slide' type='prismatic'><parent link='a'/><child link='d'/>
  <limit lower='-0.2' upper='0.1' effort='1' velocity='1'/></joint>
<joint name='twin' type='prismatic'><parent link='a'/><child link='e'/><mimic joint='slide' multiplier='2'/>
  <limit lower='-1' upper='1' effort='1' velocity='1'/></joint>
</robot>"""


def test_values_are_clamped_to_the_soft_range_and_mimic_joints_are_not_parameters() -> None:
    control = JointControl(parse_urdf(URDF))
    assert control.names == ("hinge", "wheel", "slide")
    assert control.set("hinge", 9.0) == 1.4 and control.set("hinge", -9) == 0.6
    assert control.set("wheel", 10.0) == pytest.approx(math.pi)
    assert control.set("slide", -1.0) == -0.2
    hard = JointControl(parse_urdf(URDF), soft_limits=False)
    assert hard.set("hinge", 9.0) == 1.5
    np.testing.assert_array_equal(control.positions(), [0.6, math.pi, -0.2])


@pytest.mark.parametrize("value", ["1", None, float("nan"), float("inf"), True, [1.0], {"x": 1}])
def test_a_value_that_is_no_finite_number_is_refused(value: object) -> None:
    control = JointControl(parse_urdf(URDF))
    before = control.positions()
    with pytest.raises(TrajectoryError, match="is not a finite number"):
        control.set("hinge", value)
    np.testing.assert_array_equal(control.positions(), before)


def test_unknown_and_mimic_joints_are_refused() -> None:
    control = JointControl(parse_urdf(URDF))
    for name in ("nope", "twin"):
        with pytest.raises(TrajectoryError, match="is not an actuated joint"):
            control.set(name, 0.0)


def test_center_and_randomize_as_joint_state_publisher_gui() -> None:
    control = JointControl(parse_urdf(URDF), seed=3, overrides={"slide": 0.05})
    center = control.positions()
    np.testing.assert_array_equal(center, [1.0, 0.0, 0.05])  # 0 outside the hinge's range: its middle
    version = control.version
    control.randomize()
    moved = control.positions()
    assert control.version == version + 1 and not np.array_equal(moved, center)
    assert np.all(moved >= control.lower) and np.all(moved <= control.upper)
    control.center()
    np.testing.assert_array_equal(control.positions(), center)
    again = JointControl(parse_urdf(URDF), seed=3, overrides={"slide": 0.05})
    again.randomize()
    np.testing.assert_array_equal(again.positions(), moved)  # seeded
