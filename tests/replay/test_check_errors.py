"""The re-simulation's errors computed on FK's component rows are the values of the plain formulas, bit for bit:
``np.linalg.norm`` of the translations' difference and ``rotation_error`` of the quaternions; and FK's component
layout holds :func:`dynamic_transforms`' own values."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from tests.conftest import REPO
from tfrec.description import load_description
from tfrec.errors import LegacyXacroWarning
from tfrec.kinematics.fk import dynamic_components, dynamic_transforms
from tfrec.kinematics.rotations import relative_angle, rotation_error
from tfrec.replay.check import _errors


@pytest.mark.parametrize("n", [1, 7, 5000])
def test_errors_are_norm_and_rotation_error(n: int) -> None:
    rng = np.random.default_rng(n)
    scale = rng.choice([1e-12, 1e-6, 1.0, 1e3], size=(n, 1))
    recorded_t = rng.normal(size=(n, 3)) * scale
    recorded_q = rng.normal(size=(n, 4))
    expected_t = recorded_t + rng.normal(size=(n, 3)) * scale * 1e-9
    expected_q = recorded_q + rng.normal(size=(n, 4)) * rng.choice([0.0, 1e-12, 1e-3, 1.0], size=(n, 1))
    distance, angle = _errors(recorded_t, recorded_q, np.ascontiguousarray(expected_t.T),
                              np.ascontiguousarray(expected_q.T))
    assert np.array_equal(distance, np.linalg.norm(recorded_t - expected_t, axis=1))
    assert np.array_equal(angle, rotation_error(recorded_q, expected_q))


def test_errors_against_a_fixed_transform_broadcast() -> None:
    rng = np.random.default_rng(3)
    recorded_t, recorded_q = rng.normal(size=(50, 3)), rng.normal(size=(50, 4))
    fixed_t, fixed_q = rng.normal(size=3), rng.normal(size=4)
    distance, angle = _errors(recorded_t, recorded_q, np.broadcast_to(fixed_t[:, None], (3, 50)),
                              np.broadcast_to(fixed_q[:, None], (4, 50)))
    assert np.array_equal(distance, np.linalg.norm(recorded_t - fixed_t, axis=1))
    assert np.array_equal(angle, rotation_error(recorded_q, np.broadcast_to(fixed_q, (50, 4))))


def test_relative_angle_is_rotation_error() -> None:
    rng = np.random.default_rng(4)
    qa, qb = rng.normal(size=(300, 4)), rng.normal(size=(300, 4))
    assert np.array_equal(relative_angle(list(qa.T), list(qb.T)), rotation_error(qa, qb))
    assert relative_angle(list(qa.T), list(qa.T)).max() < 1e-7


@pytest.mark.parametrize("robot", ["robots/marm.xacro", "robots/mbot.xacro"])
def test_dynamic_components_are_dynamic_transforms(robot: str) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LegacyXacroWarning)  # mbot is written in the course's dialect
        model = load_description(REPO / robot)
    names = [joint.name for joint in model.moving_joints]
    q = np.random.default_rng(5).normal(size=(9000, len(names))) * 3  # more than one of FK's blocks
    components = dynamic_components(model, names, q)
    transforms = dynamic_transforms(model, names, q)
    assert components.shape == (len(names), 7, len(q))
    assert np.array_equal(components[:, :3].transpose(2, 0, 1), transforms.translation)
    assert np.array_equal(components[:, 3:].transpose(2, 0, 1), transforms.rotation)


def test_fk_of_joints_in_any_order_is_the_same_per_joint() -> None:
    """Joints of one type taken as a slice (consecutive) or an index (interleaved) give the same values."""
    model = load_description(REPO / "robots/marm.xacro")
    names = [joint.name for joint in model.moving_joints]
    q = np.random.default_rng(6).normal(size=(100, len(names)))
    order = [len(names) - 1, 0, len(names) - 2, *range(1, len(names) - 2)]  # a prismatic joint between revolute
    straight = dynamic_components(model, names, q)
    mixed = dynamic_components(model, [names[k] for k in order], q[:, order])
    assert np.array_equal(mixed, straight[order])
