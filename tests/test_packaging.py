"""What pip may install: every dependency has a bound on its next major (an unknown major must not reach users
unannounced), and .ci/lowest.txt — the versions `make test-lowest` installs — pins each lower bound."""

from __future__ import annotations

import pytest
from packaging.requirements import Requirement
from packaging.specifiers import SpecifierSet
from packaging.utils import canonicalize_name
from packaging.version import Version

from tests.conftest import REPO

tomllib = pytest.importorskip("tomllib", reason="tomllib comes with Python >= 3.11")

PROJECT = tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))["project"]
RUNTIME = [Requirement(text) for text in PROJECT["dependencies"]]
TESTED = RUNTIME + [Requirement(text) for text in PROJECT["optional-dependencies"]["test"]]


def _lowest() -> dict[str, SpecifierSet]:
    pins = {}
    for line in (REPO / ".ci" / "lowest.txt").read_text(encoding="utf-8").splitlines():
        line = line.split("#", 1)[0].strip()
        if line:
            requirement = Requirement(line)
            pins[canonicalize_name(requirement.name)] = requirement.specifier
    return pins


def _bound(requirement: Requirement, operator: str) -> Version | None:
    found = [Version(spec.version) for spec in requirement.specifier if spec.operator == operator]
    return found[0] if found else None


@pytest.mark.parametrize("requirement", [*TESTED, *(Requirement(t) for t in PROJECT["optional-dependencies"]["lint"])],
                         ids=str)
def test_every_dependency_has_a_lower_bound_and_an_upper_bound(requirement: Requirement) -> None:
    assert _bound(requirement, ">=") is not None, f"{requirement}: no lower bound"
    assert _bound(requirement, "<") is not None, f"{requirement}: no bound on the next major"


@pytest.mark.parametrize("requirement", TESTED, ids=str)
def test_the_lowest_versions_ci_installs_are_the_lower_bounds(requirement: Requirement) -> None:
    pins = _lowest()
    name = canonicalize_name(requirement.name)
    assert name in pins, f".ci/lowest.txt has no line for {requirement.name}"
    lower = _bound(requirement, ">=")
    assert lower is not None and lower in pins[name], f".ci/lowest.txt pins {name}{pins[name]}, not {lower}"


def test_lowest_txt_names_only_dependencies() -> None:
    assert set(_lowest()) <= {canonicalize_name(r.name) for r in TESTED}
