"""check_urdf (urdfdom 3.0.1, Debian's ROS 1) against tfrec on every URDF the tests have — robots/, the course's
launch file, ../shared/corpus, example-robot-data — and on the generated edge cases of urdf_cases.py: both accept or
both refuse, and an accepted robot has the same name, root and tree. The differences on purpose are listed in
urdf_cases.DIFFERENCES (docs/ros-parity.md)."""

from __future__ import annotations

import warnings
from pathlib import Path

import pytest

from tests.conftest import CORPUS, ROBOTS
from tests.interop.conftest import add_to_figure, figure, needs
from tests.interop.ros import CheckUrdf, check_urdf
from tests.interop.urdf_cases import CASES, DIFFERENCES
from tests.test_real_robots import CORPUS_ROBOTS, ERD, ERD_URDFS
from tfrec.description import parse_urdf
from tfrec.description._load import read_description_text
from tfrec.errors import DescriptionError
from tfrec.model import Robot


def _descriptions() -> dict[str, tuple[Path, dict[str, str], list[Path]]]:
    """id → (description file, xacro arguments, package paths): every real description the tests use."""
    found: dict[str, tuple[Path, dict[str, str], list[Path]]] = {
        f"robots/{path.name}": (path, {}, [ROBOTS]) for path in sorted(ROBOTS.glob("*.xacro"))
        if path.name != "parameters.xacro"  # a file of properties that other files include: no robot
    }
    if CORPUS.is_dir():
        for name, (rel, args) in sorted(CORPUS_ROBOTS.items()):
            found[f"corpus/{name}"] = (CORPUS / rel, args, [CORPUS])
        for path in sorted(CORPUS.rglob("*.urdf")):
            found[f"corpus/{path.relative_to(CORPUS)}"] = (path, {}, [CORPUS])
    for path in ERD_URDFS:
        assert ERD is not None
        found[f"example-robot-data/{path.relative_to(ERD)}"] = (path, {}, [ERD])
    return found


DESCRIPTIONS = _descriptions()


def _tfrec(text: str) -> Robot | str:
    """tfrec's robot of a URDF text, or its error."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # left-out visuals, planar joints…: what is compared is below
            return parse_urdf(text, source="case.urdf")
    except DescriptionError as err:
        return str(err)


def _tree(robot: Robot) -> dict[str, list[str]]:
    tree: dict[str, list[str]] = {link.name: [] for link in robot.links}
    for joint in robot.joints:
        tree[joint.parent].append(joint.child)
    return {link: sorted(children) for link, children in tree.items()}


def _agree(oracle: CheckUrdf, ours: Robot | str) -> str:
    """Where tfrec and check_urdf disagree, in words; ``""`` when they agree."""
    if oracle.endless:
        return "check_urdf's tree never ends (a cycle urdfdom let through)"
    if oracle.accepted != isinstance(ours, Robot):
        return (f"check_urdf {'accepts' if oracle.accepted else 'refuses'} it, tfrec "
                f"{'accepts' if isinstance(ours, Robot) else 'refuses'} it: {ours if isinstance(ours, str) else ''}"
                f" / check_urdf: {oracle.output.strip()[:300]}")
    if not isinstance(ours, Robot):
        return ""
    if (oracle.name, oracle.root) != (ours.name, ours.root):
        return f"name, root: check_urdf {(oracle.name, oracle.root)}, tfrec {(ours.name, ours.root)}"
    theirs = {link: sorted(children) for link, children in oracle.tree.items()}
    return "" if theirs == _tree(ours) else f"trees differ: check_urdf {theirs}, tfrec {_tree(ours)}"


@pytest.fixture(scope="module")
def scratch(tmp_path_factory: pytest.TempPathFactory) -> Path:
    needs("check_urdf")
    return tmp_path_factory.mktemp("check_urdf")


@pytest.mark.parametrize("name", sorted(DESCRIPTIONS))
def test_check_urdf_and_tfrec_agree_on_every_real_description(name: str, scratch: Path) -> None:
    path, args, package_paths = DESCRIPTIONS[name]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        text, _ = read_description_text(path, args=args, package_paths=package_paths)  # xacro expanded, as ROS would
    urdf = scratch / "real.urdf"
    urdf.write_text(text, encoding="utf-8")
    oracle, ours = check_urdf(urdf, scratch), _tfrec(text)
    assert _agree(oracle, ours) == ""
    add_to_figure("check_urdf: real descriptions agreeing", 1)
    add_to_figure(f"check_urdf: real descriptions {'accepted' if oracle.accepted else 'refused'} by both", 1)


@pytest.mark.parametrize("case", sorted(CASES))
def test_check_urdf_and_tfrec_agree_on_generated_edge_cases(case: str, scratch: Path) -> None:
    urdf = scratch / "case.urdf"
    urdf.write_text(CASES[case], encoding="utf-8")
    oracle, ours = check_urdf(urdf, scratch), _tfrec(CASES[case])
    problem = _agree(oracle, ours)
    if case in DIFFERENCES:  # on purpose: the difference is still there, and is the one documented
        assert problem, f"{case} agrees now: take it out of DIFFERENCES ({DIFFERENCES[case]})"
        add_to_figure("check_urdf: edge cases differing on purpose", 1)
        return
    assert problem == ""
    add_to_figure("check_urdf: edge cases agreeing", 1)


def test_the_figures_count_every_case() -> None:
    figure("check_urdf: edge cases", len(CASES))
    figure("check_urdf: real descriptions", len(DESCRIPTIONS))
    assert len(CASES) > 200 and len(DESCRIPTIONS) >= (80 if ERD_URDFS and CORPUS.is_dir() else 3)
