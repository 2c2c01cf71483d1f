"""Every Python example in docs/api.md runs as it is, from the repository's root."""

from __future__ import annotations

import re
import warnings

import pytest

from tests.conftest import REPO

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
        pytest.skip(f"{REPO.parent / 'shared' / 'corpus'} is absent")
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
