"""Every Python example in docs/api.md runs as it is, from the repository's root."""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import pytest

from tests.conftest import CORPUS_ABSENT, REPO

API = REPO / "docs" / "api.md"
_BLOCK = re.compile(r"```python\n(.*?)```", re.DOTALL)


def _examples() -> list[tuple[str, str]]:
    text = API.read_text(encoding="utf-8")
    out = []
    for match in _BLOCK.finditer(text):
        line = text.count("\n", 0, match.start()) + 1
        out.append((f"api.md:{line}", match.group(1)))
    return out


@pytest.mark.parametrize(("where", "code"), _examples(), ids=[where for where, _ in _examples()])
def test_api_example_runs(where: str, code: str, monkeypatch: pytest.MonkeyPatch,
                          capsys: pytest.CaptureFixture[str]) -> None:
    if "../shared/corpus" in code and not (REPO.parent / "shared" / "corpus").is_dir():  # the examples' own path
        pytest.skip(CORPUS_ABSENT)
    monkeypatch.chdir(REPO)
    with warnings.catch_warnings():  # an example may warn (mbot's legacy macro calls): that is not a failure
        warnings.simplefilter("ignore")
        exec(compile(code, where, "exec"), {"__name__": "__docs__"})  # noqa: S102 - our own documentation
    assert capsys.readouterr().out.strip(), f"{where} prints nothing"


def test_every_public_name_is_documented() -> None:
    import tfrec

    text = API.read_text(encoding="utf-8")
    missing = [name for name in tfrec.__all__ if name != "__version__" and f"`{name}" not in text]
    assert not missing, f"docs/api.md does not document {missing}"


README = REPO / "README.md"
_CONSOLE = re.compile(r"```console\n(.*?)```", re.DOTALL)
_TIMING = re.compile(r"\bin \d+(\.\d+)? s\b")


def test_readme_tour_works_as_typed(tmp_path: Path) -> None:
    """The README's tour, run in a copy of the repository's robots/: every output line it shows is printed,
    in that order, by the commands as typed (`...` stands for lines left out; timings may differ)."""
    import shutil
    import subprocess
    import sys

    work = tmp_path
    text = README.read_text(encoding="utf-8")
    block = _CONSOLE.search(text)
    assert block, "README.md has no console tour"
    commands, shown = [], []
    for line in block.group(1).splitlines():
        if line.startswith("$ "):
            commands.append(line[2:])
        elif line.strip() and line.strip() != "...":
            shown.append(line)
    assert commands[0] == ". .venv/bin/activate"
    shutil.copytree(REPO / "robots", work / "robots")
    (work / ".venv").symlink_to(Path(sys.prefix))  # the tour activates the project's environment
    script = "\n".join(commands) + "\n"
    run = subprocess.run(["bash", "-c", script], cwd=work, capture_output=True, text=True, timeout=600,
                         check=False)
    printed = [_TIMING.sub("in T s", out) for out in run.stdout.splitlines()]
    position = 0
    for expected in shown:
        expected = _TIMING.sub("in T s", expected)
        try:
            position = printed.index(expected, position) + 1
        except ValueError:
            raise AssertionError(f"README shows {expected!r} but the tour printed (from line {position}):\n"
                                 + "\n".join(printed[position:position + 40])
                                 + f"\nstderr:\n{run.stderr}") from None
    for name in ("marm.mcap", "marm.rrd", "marm-tree.png", "marm-check.png", "marm4.bag", "marm-diff.png",
                 "marm-vs-long.rrd", "marm-vs-long.png", "marm4-tail.mcap", "marm-joints.png", "fleet.parquet", "cube.mcap"):
        assert (work / name).stat().st_size > 0, name
