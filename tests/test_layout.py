"""The layout stays what docs/architecture.md says (import rules are kept by `make lint`)."""

from __future__ import annotations

import ast

from tests.conftest import REPO

PACKAGE = REPO / "tfrec"


def test_at_most_18_modules_at_the_top() -> None:
    """The top holds the base (errors, model, recording, frames, conventions, outputs, the address space), the package
    face and what sits beside the stages (recorder, info, robots, resample, the pytest plugin pytest11 names):
    anything else belongs in a stage's folder."""
    modules = sorted(path.name for path in PACKAGE.glob("*.py"))
    assert len(modules) <= 18, modules


def test_every_subpackage_has_a_docstring_and_all() -> None:
    for init in sorted(PACKAGE.rglob("__init__.py")):
        tree = ast.parse(init.read_text(encoding="utf-8"))
        assert ast.get_docstring(tree), f"{init} has no docstring"
        names = [t.id for node in tree.body if isinstance(node, ast.Assign) for t in node.targets
                 if isinstance(t, ast.Name)]
        assert "__all__" in names, f"{init} has no __all__"


def test_format_libraries_only_in_formats_and_xacro_only_in_description() -> None:
    """What ruff's banned-api enforces in `make lint`, checked here too (also lazy imports in functions)."""
    formats_only = {"mcap", "mcap_ros2", "rosbags", "rerun", "pyarrow", "zstandard", "lz4"}
    for path in PACKAGE.rglob("*.py"):
        inside = path.relative_to(PACKAGE).parts[0]
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import)
                     else [node.module or ""] if isinstance(node, ast.ImportFrom) and node.level == 0 else [])
            for name in names:
                top = name.split(".")[0]
                assert top not in formats_only or inside == "formats" or (top in ("rerun", "pyarrow") and inside == "viewer") or (
                    top == "pyarrow" and path == PACKAGE / "fleet" / "report.py"), f"{path} imports {name}"
                assert top != "yaml" or inside == "_yaml.py", f"{path} imports {name}"
                assert top != "xacro" or inside == "description", f"{path} imports {name}"
                assert top != "matplotlib" or inside == "plots", f"{path} imports {name}"
                assert top != "ray" or inside == "fleet", f"{path} imports {name}"
                assert top != "foxglove" or inside == "live", f"{path} imports {name}"


def test_every_entry_of_the_slow_tier_names_a_test() -> None:
    """A renamed test must not drop out of the slow tier (and into ``make test``) unnoticed."""
    from tests.conftest import SLOW_TIER

    for entry in SLOW_TIER:
        file, _, name = entry.partition("::")
        path = REPO / file
        assert path.is_file(), entry
        assert not name or f"def {name.partition('[')[0]}" in path.read_text(encoding="utf-8"), entry


def test_every_warning_of_tfrec_has_its_category() -> None:
    """``-W error::tfrec.TfrecWarning`` (and pytest's ``filterwarnings``) reach every warning tfrec gives: each
    ``warnings.warn`` in tfrec/ names ``TfrecWarning`` (or a subclass), passes such a warning, or relays a caught
    warning with its own category."""
    import tfrec.errors

    categories = {name for name, value in vars(tfrec.errors).items()
                  if isinstance(value, type) and issubclass(value, tfrec.errors.TfrecWarning)}
    for path in PACKAGE.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if not (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == "warn"
                    and isinstance(node.func.value, ast.Name) and node.func.value.id == "warnings"):
                continue
            where = f"{path.relative_to(REPO)}:{node.lineno}"
            category = node.args[1] if len(node.args) > 1 else next(
                (k.value for k in node.keywords if k.arg == "category"), None)
            first = node.args[0]
            if isinstance(first, ast.Call) and isinstance(first.func, ast.Name) and first.func.id.endswith("Warning"):
                assert first.func.id in categories, where
            elif isinstance(category, ast.Name):
                assert category.id in categories, where
            else:
                assert isinstance(category, ast.Attribute) and category.attr == "category", where
