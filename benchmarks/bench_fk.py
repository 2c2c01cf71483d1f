"""Forward kinematics speed: tfrec's batched FK against yourdfpy, link poses per second.

Both compute root → link 4×4 poses for every link of a 7-DoF arm (Franka Panda from
../shared/corpus, or an inline 7-DoF URDF when the corpus is absent) at random
configurations within the joint limits. tfrec does all configurations in one batch
(joint states, per-joint transforms, composition, matrices); yourdfpy does
``update_cfg`` + ``get_transform`` per configuration and link, timed on the first 500
configurations (it is ~300 times slower) and reported as a rate. Each side counts its
fastest run. Run from the repository root:

    .venv/bin/python benchmarks/bench_fk.py
"""

from __future__ import annotations

import argparse
import io
import sys
from pathlib import Path

import numpy as np
from _common import best_of, machine

from tfrec.description import load_description, parse_urdf
from tfrec.kinematics.fk import dynamic_transforms, link_poses
from tfrec.kinematics.joints import all_joint_states
from tfrec.model import Robot
from tfrec.trajectory.joints import joint_bounds
from tfrec.trajectory.types import JointTrajectory

CORPUS = Path(__file__).resolve().parents[2] / "shared" / "corpus"
PANDA = CORPUS / "franka_description" / "robots" / "panda" / "panda.urdf.xacro"
TARGET = 200.0


def _inline_arm() -> str:
    """A 7-DoF arm with Panda-like geometry (used when the corpus is absent)."""
    joints = [
        ("0 0 0.333", "0 0 0", -2.8973, 2.8973),
        ("0 0 0", "-1.5708 0 0", -1.7628, 1.7628),
        ("0 -0.316 0", "1.5708 0 0", -2.8973, 2.8973),
        ("0.0825 0 0", "1.5708 0 0", -3.0718, -0.0698),
        ("-0.0825 0.384 0", "-1.5708 0 0", -2.8973, 2.8973),
        ("0 0 0", "1.5708 0 0", -0.0175, 3.7525),
        ("0.088 0 0", "1.5708 0 0", -2.8973, 2.8973),
    ]
    parts = ['<robot name="arm7">', '<link name="link0"/>']
    for i, (xyz, rpy, lower, upper) in enumerate(joints, start=1):
        parts.append(
            f'<link name="link{i}"/><joint name="joint{i}" type="revolute"><parent link="link{i - 1}"/>'
            f'<child link="link{i}"/><origin xyz="{xyz}" rpy="{rpy}"/><axis xyz="0 0 1"/>'
            f'<limit lower="{lower}" upper="{upper}" effort="87" velocity="2.175"/></joint>'
        )
    parts.append('<link name="link8"/><joint name="joint8" type="fixed"><parent link="link7"/>'
                 '<child link="link8"/><origin xyz="0 0 0.107"/></joint></robot>')
    return "".join(parts)


def _load_arm() -> tuple[Robot, str]:
    if PANDA.is_file():
        return load_description(PANDA, package_paths=[CORPUS]), f"Franka Panda ({PANDA.relative_to(CORPUS)})"
    return parse_urdf(_inline_arm()), "inline 7-DoF arm (corpus absent)"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--configs", type=int, default=10_000, help="configurations for tfrec (default 10000)")
    parser.add_argument("--yourdfpy-configs", type=int, default=500, help="configurations timed for yourdfpy")
    parser.add_argument("--repeat", type=int, default=5, help="tfrec runs; the fastest counts (default 5)")
    parser.add_argument("--repeat-yourdfpy", type=int, default=3, help="yourdfpy runs; the fastest counts (default 3)")
    parser.add_argument("--seed", type=int, default=0)
    options = parser.parse_args(argv)

    import yourdfpy

    robot, label = _load_arm()
    lower, upper = np.array([joint_bounds(j) for j in robot.actuated_joints]).T
    rng = np.random.default_rng(options.seed)
    positions = rng.uniform(lower, upper, size=(options.configs, len(lower)))
    trajectory = JointTrajectory(
        tuple(j.name for j in robot.actuated_joints),
        np.arange(options.configs, dtype=np.int64),
        positions,
        np.zeros_like(positions),
    )
    links = [link.name for link in robot.links]

    def tfrec_fk() -> dict[str, np.ndarray]:
        names, q, _ = all_joint_states(robot, trajectory)
        return link_poses(robot, names, q)

    def tfrec_joint_transforms() -> None:
        names, q, _ = all_joint_states(robot, trajectory)
        dynamic_transforms(robot, names, q)

    tfrec_fk()  # warm up
    tfrec_s = best_of(options.repeat, tfrec_fk)
    joint_s = best_of(options.repeat, tfrec_joint_transforms)
    poses = tfrec_fk()

    model = yourdfpy.URDF.load(io.BytesIO(robot.urdf.encode()), load_meshes=False)
    subset = positions[: options.yourdfpy_configs]

    def yourdfpy_fk() -> None:
        for cfg in subset:
            model.update_cfg(cfg)
            for link in links:
                model.get_transform(link)

    yourdfpy_s = best_of(options.repeat_yourdfpy, yourdfpy_fk)
    worst = 0.0
    for i in range(0, len(subset), 50):  # agreement, checked outside the timed runs
        model.update_cfg(subset[i])
        worst = max(worst, max(float(np.abs(model.get_transform(link) - poses[link][i]).max()) for link in links))

    tfrec_rate = options.configs * len(links) / tfrec_s
    yourdfpy_rate = len(subset) * len(links) / yourdfpy_s
    ratio = tfrec_rate / yourdfpy_rate
    print(f"robot: {label}: {len(robot.actuated_joints)} actuated joints, {len(links)} links")
    print(machine("yourdfpy"))
    print(f"tfrec batched FK: {options.configs:,} configurations x {len(links)} links in "
          f"{tfrec_s * 1e3:.1f} ms (best of {options.repeat}) = {tfrec_rate:,.0f} link poses/s")
    print(f"tfrec per-joint transforms only (what /tf records): {joint_s * 1e3:.1f} ms = "
          f"{options.configs * len(robot.moving_joints) / joint_s:,.0f} joint transforms/s")
    print(f"yourdfpy update_cfg + get_transform: {len(subset):,} configurations x {len(links)} links in "
          f"{yourdfpy_s:.2f} s (best of {options.repeat_yourdfpy}) = {yourdfpy_rate:,.0f} link poses/s")
    print(f"largest difference tfrec - yourdfpy on spot checks: {worst:.1e}")
    print(f"ratio: {ratio:,.0f}x; target >= {TARGET:.0f}x: {'met' if ratio >= TARGET else 'NOT met'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
