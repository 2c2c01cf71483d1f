"""A recorded description parsed once for the pieces of a recording (and A and B of a diff), its warnings given
each time as parsing it again gives them (:class:`tfrec.robots.ParsedDescriptions`)."""

from __future__ import annotations

import warnings

import pytest

from tfrec import robots
from tfrec.robots import ParsedDescriptions, parse_description

# a typo urdfdom ignores: tfrec warns of it
URDF = """<robot name="r"><link name="a"/><link name="b"/>
<joint name="j" type="revolute"><parent link="a"/><child link="b"/><orgin xyz="0 0 1"/>
<limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>"""


def _said(call: object) -> tuple[object, list[str]]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = call()  # type: ignore[operator]
    return result, [f"{w.category.__name__}: {w.message}" for w in caught]


def test_a_description_is_parsed_once_and_warns_each_time(monkeypatch: pytest.MonkeyPatch) -> None:
    (model, problem), direct = _said(lambda: parse_description(URDF, "a.mcap"))
    assert model is not None and problem is None and any("orgin" in line for line in direct)
    parsed_texts: list[str] = []

    def counted(text: str, where: str) -> tuple[object, str | None]:
        parsed_texts.append(text)
        return parse_description(text, where)  # type: ignore[return-value]

    monkeypatch.setattr(robots, "parse_description", counted)
    memo = ParsedDescriptions()
    first = None
    for _ in range(3):
        (again, _problem), said = _said(lambda: memo.parse(URDF, "a.mcap"))
        first = first or again
        assert again == model and again is first and said == direct
    assert parsed_texts == [URDF]
    (none, why), said = _said(lambda: memo.parse("<robot", "b.mcap"))
    assert none is None and why and said == []
    assert memo.parse("<robot", "b.mcap") == (None, why) and parsed_texts == [URDF, "<robot"]


def test_default_warnings_are_shown_once() -> None:
    """Under Python's default action, what two recordings sharing a description warn is shown once, as it was when
    each parsed its own."""
    memo = ParsedDescriptions()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("default")
        memo.parse(URDF, "a.mcap")
        memo.parse(URDF, "b.mcap")
    assert len(caught) == len(_said(lambda: parse_description(URDF, "a.mcap"))[1]) > 0


def test_a_filter_on_the_warning_module_still_matches() -> None:
    """A filter on the module a warning names (``-W ignore::TfrecWarning:tfrec.robots``: where parsing a recorded
    description warns from) silences the warnings given again as it silences parsing's own."""
    memo = ParsedDescriptions()
    _said(lambda: memo.parse(URDF, "a.mcap"))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        warnings.filterwarnings("ignore", module=r"tfrec\.robots$")
        memo.parse(URDF, "a.mcap")
        parse_description(URDF, "a.mcap")
    assert caught == []
