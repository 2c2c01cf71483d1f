"""Fixtures of the fleet tests: a folder of recordings with known verdicts, made once per session."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.fleet.helpers import make_fleet


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", "ray: starts a Ray cluster (select with -m ray, skip with -m 'not ray')")


@pytest.fixture(scope="session")
def fleet_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Recordings of :data:`tests.fleet.helpers.EXPECTED` (do not modify: copy it first)."""
    return make_fleet(tmp_path_factory.mktemp("fleet"))
