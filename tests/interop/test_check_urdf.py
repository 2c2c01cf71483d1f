"""check_urdf (urdfdom 3.0.1, Debian's ROS 1) against `tfrec inspect --json` on every URDF the tests have — robots/, the course's
launch file, ../shared/corpus, example-robot-data — and on the generated edge cases of urdf_cases.py: both accept or
both refuse, and an accepted robot has the same name, root and tree. The differences on purpose are listed in
urdf_cases.DIFFERENCES (docs/ros-parity.md)."""

from __future__ import annotations

import json
import warnings
from dataclasses import dataclass
from pathlib import Path

import pytest

from tests.conftest import CORPUS, ROBOTS
from tests.interop.conftest import add_to_figure, figure, needs
from tests.interop.ros import CheckUrdf, check_urdf
from tests.interop.urdf_cases import CASES, DIFFERENCES
from tests.test_real_robots import CORPUS_ROBOTS, ERD, ERD_URDFS
from tfrec import cli
from tfrec.description._load import read_description_text


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


@dataclass(frozen=True)
class Inspected:
    """What `tfrec inspect --json` said of a description."""

    name: str
    root: str
    tree: dict[str, list[str]]


def _inspect(path: Path, args: dict[str, str], package_paths: list[Path],
             capsys: pytest.CaptureFixture[str]) -> Inspected | str:
    """`tfrec inspect FILE --json` (the command, in-process): the robot, or its one-line error."""
    argv = ["inspect", str(path), *(f"{k}:={v}" for k, v in args.items()), "--json"]
    for folder in package_paths:
        argv += ["--package-path", str(folder)]
    code = cli.main(argv)
    out, err = capsys.readouterr()
    if code != 0:
        assert code == 2 and err.startswith("tfrec: error: ") and err.count("\n") == 1, err
        return err.removeprefix("tfrec: error: ").strip()
    found = json.loads(out)
    tree: dict[str, list[str]] = {link: [] for link in found["links"]}
    for joint in found["joints"]:
        tree[joint["parent"]].append(joint["child"])
    return Inspected(found["name"], found["root"], {link: sorted(children) for link, children in tree.items()})


def _agree(oracle: CheckUrdf, ours: Inspected | str) -> str:
    """Where tfrec and check_urdf disagree, in words; ``""`` when they agree."""
    if oracle.endless:
        return "check_urdf's tree never ends (a cycle urdfdom let through)"
    if oracle.accepted != isinstance(ours, Inspected):
        return (f"check_urdf {'accepts' if oracle.accepted else 'refuses'} it, tfrec "
                f"{'accepts' if isinstance(ours, Inspected) else 'refuses'} it: {ours if isinstance(ours, str) else ''}"
                f" / check_urdf: {oracle.output.strip()[:300]}")
    if not isinstance(ours, Inspected):
        return ""
    if (oracle.name, oracle.root) != (ours.name, ours.root):
        return f"name, root: check_urdf {(oracle.name, oracle.root)}, tfrec {(ours.name, ours.root)}"
    theirs = {link: sorted(children) for link, children in oracle.tree.items()}
    return "" if theirs == ours.tree else f"trees differ: check_urdf {theirs}, tfrec {ours.tree}"


@pytest.fixture(scope="module")
def scratch(tmp_path_factory: pytest.TempPathFactory) -> Path:
    needs("check_urdf")
    return tmp_path_factory.mktemp("check_urdf")


@pytest.mark.parametrize("name", sorted(DESCRIPTIONS))
def test_check_urdf_and_tfrec_agree_on_every_real_description(name: str, scratch: Path,
                                                               capsys: pytest.CaptureFixture[str]) -> None:
    path, args, package_paths = DESCRIPTIONS[name]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        text, _ = read_description_text(path, args=args, package_paths=package_paths)  # xacro expanded, as ROS would
    urdf = scratch / "real.urdf"
    urdf.write_text(text, encoding="utf-8")
    oracle, ours = check_urdf(urdf, scratch), _inspect(path, args, package_paths, capsys)
    assert _agree(oracle, ours) == ""
    add_to_figure("check_urdf: real descriptions agreeing", 1)
    add_to_figure(f"check_urdf: real descriptions {'accepted' if oracle.accepted else 'refused'} by both", 1)


@pytest.mark.parametrize("case", sorted(CASES))
def test_check_urdf_and_tfrec_agree_on_generated_edge_cases(case: str, scratch: Path,
                                                            capsys: pytest.CaptureFixture[str]) -> None:
    urdf = scratch / "case.urdf"
    urdf.write_text(CASES[case], encoding="utf-8")
    oracle, ours = check_urdf(urdf, scratch), _inspect(urdf, {}, [], capsys)
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
