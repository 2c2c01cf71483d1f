"""Shared fixtures: the repository's robots and the real packages in ../shared/corpus."""

from __future__ import annotations

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
ROBOTS = REPO / "robots"
CORPUS = REPO.parent / "shared" / "corpus"


@pytest.fixture
def robots() -> Path:
    return ROBOTS


@pytest.fixture
def corpus() -> Path:
    if not CORPUS.is_dir():
        pytest.skip("../shared/corpus is absent")
    return CORPUS
