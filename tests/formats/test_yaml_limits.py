"""The hardened YAML loader: real files load as ``yaml.safe_load`` loads them; alias bombs, deep
nesting and oversized documents are refused quickly, in one line that starts with ``where``."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.conftest import BAGS, BAGS_ABSENT, CORPUS, CORPUS_ABSENT
from tfrec._yaml import MAX_DEPTH, _Refused, load_yaml
from tfrec.errors import ReadError

METADATA = sorted((BAGS / "rosbag2").glob("*/metadata.yaml"))
CONFIGS = sorted(CORPUS.glob("**/*.yaml"))
UNITS: dict[str, Callable[[str], Any]] = {
    "!radians": float, "!degrees": lambda s: float(s) * math.pi / 180, "!meters": float,
    "!millimeters": lambda s: float(s) * 0.001, "!foot": lambda s: float(s) * 0.3048,
    "!inches": lambda s: float(s) * 0.0254,
}


def reference_load(text: str) -> Any:
    """``yaml.safe_load`` with the same unit constructors, on a loader class of its own."""
    loader: Any = type("Reference", (yaml.SafeLoader,), {})
    loader.yaml_constructors = dict(yaml.SafeLoader.yaml_constructors)
    for tag, construct in UNITS.items():
        loader.add_constructor(tag, lambda loader, node, c=construct: c(loader.construct_scalar(node)))
    return yaml.load(text, Loader=loader)  # a SafeLoader subclass


# ---- real files load identically -----------------------------------------------------------


@pytest.mark.skipif(not METADATA, reason=BAGS_ABSENT)
@pytest.mark.parametrize("path", METADATA, ids=[p.parent.name for p in METADATA])
def test_rosbag2_metadata_loads_as_safe_load(path: Path) -> None:
    text = path.read_text(encoding="utf-8")
    assert load_yaml(text, where=str(path)) == yaml.safe_load(text)
    assert load_yaml(path.read_bytes(), where=str(path)) == yaml.safe_load(text)


@pytest.mark.skipif(not CONFIGS, reason=CORPUS_ABSENT)
@pytest.mark.parametrize("path", CONFIGS, ids=[str(p.relative_to(CORPUS)) for p in CONFIGS])
def test_corpus_yaml_loads_as_safe_load(path: Path) -> None:
    text = path.read_text(encoding="utf-8")
    assert load_yaml(text, where=str(path), constructors=UNITS) == reference_load(text)


def test_the_offered_qos_text_inside_metadata_loads() -> None:
    text = "- history: 3\n  depth: 0\n  durability: 2\n  deadline:\n    sec: 0\n    nsec: 0\n"
    assert load_yaml(text, where="offered_qos_profiles") == yaml.safe_load(text)


yaml_data = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False) | st.text(max_size=8),
    lambda children: st.lists(children, max_size=4) | st.dictionaries(st.text(max_size=6), children, max_size=4),
    max_leaves=30,
)


@settings(max_examples=200, deadline=None)
@given(yaml_data, st.booleans())
def test_any_document_loads_as_safe_load(data: Any, flow: bool) -> None:
    text = yaml.safe_dump(data, default_flow_style=flow)
    assert load_yaml(text, where="x.yaml") == yaml.safe_load(text)


def test_shared_anchors_load_and_stay_shared() -> None:
    text = "base: &b {x: 1, y: [1, 2]}\nleft: *b\nright: *b\n"
    data = load_yaml(text, where="x.yaml")
    assert data == yaml.safe_load(text)
    assert data["left"] is data["right"]


def test_constructors_apply_to_one_call_only() -> None:
    assert load_yaml("a: !degrees 180\n", where="x.yaml", constructors=UNITS) == {"a": math.pi}
    with pytest.raises(ValueError, match=r"^x\.yaml:1: not valid YAML: could not determine a constructor"):
        load_yaml("a: !degrees 180\n", where="x.yaml")


def test_xacros_global_units_do_not_leak_in(tmp_path: Path) -> None:
    """Stock xacro registers !degrees on yaml.SafeLoader itself: metadata must not understand it."""
    import xacro

    (tmp_path / "units.yaml").write_text("a: !degrees 180\n", encoding="utf-8")
    xacro.init_stacks(None)
    assert xacro.load_yaml(str(tmp_path / "units.yaml")) == {"a": math.pi}
    assert "!degrees" in yaml.SafeLoader.yaml_constructors
    with pytest.raises(ValueError, match=r"could not determine a constructor for the tag '!degrees'"):
        load_yaml("a: !degrees 180\n", where="x.yaml")


# ---- what is refused ---------------------------------------------------------------------


def billion_laughs(levels: int = 9, width: int = 10) -> str:
    lines = ['a0: &a0 ["lol"]']
    for i in range(1, levels + 1):
        lines.append(f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * width) + "]")
    return "\n".join(lines) + "\n"


def test_billion_laughs_is_refused_quickly() -> None:
    text = billion_laughs()
    assert len(text) < 1000
    start = time.process_time()
    with pytest.raises(ValueError, match=r"^bomb\.yaml: YAML expands to more than 2,000,000 nodes"):
        load_yaml(text, where="bomb.yaml")
    assert time.process_time() - start < 30  # a hang guard in CPU seconds: expanded, it would never end
    assert load_yaml(billion_laughs(levels=3), where="small.yaml") == yaml.safe_load(billion_laughs(levels=3))


def test_too_many_aliases_are_refused() -> None:
    text = "a: &a 1\nb: [" + ", ".join(["*a"] * 50) + "]\n"
    with pytest.raises(ValueError, match=r"^x\.yaml: YAML uses more than 10 aliases"):
        load_yaml(text, where="x.yaml", max_aliases=10)
    assert load_yaml(text, where="x.yaml", max_aliases=50)["b"] == [1] * 50


def test_a_recursive_alias_is_refused() -> None:
    with pytest.raises(ValueError, match=r"^x\.yaml: YAML alias \*a refers to a collection that holds it"):
        load_yaml("a: &a [1, *a]\n", where="x.yaml")


@pytest.mark.parametrize("text", [
    "[" * 20_000 + "]" * 20_000,
    "{a: " * 20_000 + "1" + "}" * 20_000,
    "".join("  " * i + "-\n" for i in range(2_000)) + "  " * 2_000 + "x\n",
    "".join("  " * i + f"k{i}:\n" for i in range(2_000)) + "  " * 2_000 + "v\n",
    "- " * 20_000 + "x\n",
], ids=["flow sequences", "flow mappings", "block sequences", "block mappings", "compact sequences"])
def test_deep_nesting_is_refused_without_recursion_error(text: str) -> None:
    """Refused in one line that names the file — by tfrec's own bound, or first by the parser's (libyaml in
    PyYAML >= 6.0.3 refuses flow collections nested 1,000 deep while scanning, in its own words)."""
    start = time.process_time()
    with pytest.raises(ValueError, match=r"^deep\.yaml(:\d+)?: \S") as caught:
        load_yaml(text, where="deep.yaml")
    assert time.process_time() - start < 30  # a hang guard in CPU seconds
    assert "\n" not in str(caught.value)
    assert not isinstance(caught.value.__cause__, RecursionError)
    if isinstance(caught.value.__cause__, _Refused):
        assert str(caught.value) == f"deep.yaml: YAML nested more than {MAX_DEPTH} levels deep"


@pytest.mark.parametrize("levels", [MAX_DEPTH + 1, 100, 999])
def test_nesting_past_the_bound_is_refused_by_tfrec(levels: int) -> None:
    """Below any parser's own limit, tfrec's bound refuses in tfrec's words."""
    for text in ("[" * levels + "]" * levels, "{a: " * levels + "1" + "}" * levels, "- " * levels + "x\n"):
        with pytest.raises(ValueError, match=rf"^deep\.yaml: YAML nested more than {MAX_DEPTH} levels deep$"):
            load_yaml(text, where="deep.yaml")


def test_nesting_to_the_bound_loads() -> None:
    text = "[" * MAX_DEPTH + "]" * MAX_DEPTH
    assert load_yaml(text, where="x.yaml") == yaml.safe_load(text)


def test_a_large_document_is_refused_before_parsing() -> None:
    with pytest.raises(ValueError, match=r"^big\.yaml: YAML document of 101 bytes is larger than the 100 allowed"):
        load_yaml(b"x" * 101, where="big.yaml", max_bytes=100)
    with pytest.raises(ValueError, match=r"of 101 characters"):
        load_yaml("x" * 101, where="big.yaml", max_bytes=100)


@pytest.mark.parametrize("text, message", [
    ("rosbag2_bagfile_information: [\n", (r"^bad\.yaml:2: not valid YAML: expected the node content, but found "
                                          r"'<stream end>'$")),
    ("a: [1, 2\n", r"^bad\.yaml:2: not valid YAML: expected ',' or ']', but got '<stream end>'$"),
    ("a: b: c\n", r"^bad\.yaml:1: not valid YAML: mapping values are not allowed here$"),
    ("a: *nothing\n", r"^bad\.yaml:1: not valid YAML: found undefined alias 'nothing'$"),
    ("--- 1\n--- 2\n", (r"^bad\.yaml:2: not valid YAML: expected a single document in the stream, but found "
                         r"another document$")),
    ("a:\n\t- b\n", r"^bad\.yaml:2: not valid YAML: found character '\\t' that cannot start any token$"),
    ("a: !!python/object:os.system x\n", r"^bad\.yaml:1: not valid YAML: could not determine a constructor"),
])
def test_invalid_yaml_is_one_line(text: str, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        load_yaml(text, where="bad.yaml")


def test_invalid_utf8_is_one_line() -> None:
    with pytest.raises(ValueError, match=r"^bad\.yaml: not valid YAML: unacceptable character #x00ff"):
        load_yaml(b"a: \xff\xfe\n", where="bad.yaml")


def test_the_error_type_is_the_callers() -> None:
    with pytest.raises(ReadError, match=r"^meta\.yaml: YAML nested more than 3 levels deep$") as caught:
        load_yaml("[[[[1]]]]", where="meta.yaml", max_depth=3, error=ReadError)
    assert caught.value.__cause__ is not None  # the cause is chained
    with pytest.raises(ReadError, match=r"^meta\.yaml:\d+: not valid YAML"):
        load_yaml("[", where="meta.yaml", error=ReadError)


def test_utf16_with_a_byte_order_mark_loads() -> None:
    text = "name: röbot\nvalues: [1, 2]\n"
    assert load_yaml(text.encode("utf-16"), where="x.yaml") == yaml.safe_load(text)
