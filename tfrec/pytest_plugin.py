"""tfrec's pytest plugin: robot-motion regression tests against golden recordings (docs/regression.md).

Registered through the ``pytest11`` entry point, so installing tfrec is enough. The fixture
``tfrec_golden`` records a description along a trajectory and compares it with a golden recording kept
beside the test, ``<test folder>/<test module>/<test name>.mcap``::

    def test_arm(tfrec_golden):
        tfrec_golden.check("robots/arm.xacro", traj="sine", duration=2, seed=0)

``pytest --tfrec-update`` writes (or rewrites) the goldens; a missing golden fails with one line saying
how to make it; goldens no test used are listed at the end of the session. A failure shows the diff
report and writes the two robots as a ghost overlay (``.rrd``) and the error plot (``.png``) into the
test's ``tmp_path`` (or ``--tfrec-artifacts DIR``). Nothing of tfrec is imported until a test uses the
fixture.
"""

from __future__ import annotations

import os
import re
from collections.abc import Generator, Iterator, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest

if TYPE_CHECKING:
    from tfrec.recorder import Recipe

__all__ = ["TfrecGolden"]

_USED = pytest.StashKey[set[Path]]()
_FOLDERS = pytest.StashKey[set[Path]]()
_WRITTEN = pytest.StashKey[list[Path]]()
_NOT_RUN = pytest.StashKey[set[Path]]()  # golden folders of modules of which a test did not run


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("tfrec", "tfrec robot-motion regression tests")
    group.addoption("--tfrec-update", action="store_true", default=False,
                    help="write (or rewrite) the golden recordings tfrec_golden.check compares with")
    group.addoption("--tfrec-artifacts", metavar="DIR", default=None,
                    help="write a failing check's overlay .rrd and error plot into DIR/<test> instead of the "
                         "test's tmp_path")


def pytest_configure(config: pytest.Config) -> None:
    config.stash[_USED] = set()
    config.stash[_FOLDERS] = set()
    config.stash[_NOT_RUN] = set()
    config.stash[_WRITTEN] = []


def pytest_deselected(items: list[pytest.Item]) -> None:
    """A module of which a test is not run this time (``-k``, ``--deselect``): its goldens are not listed as
    unused (the test may use any name)."""
    for item in items:
        item.config.stash[_NOT_RUN].add(_golden_folder(item).resolve())


def pytest_collection_finish(session: pytest.Session) -> None:
    """The golden folders of the test modules collected: where unused goldens are looked for."""
    folders = session.config.stash[_FOLDERS]
    for item in session.items:
        folder = _golden_folder(item)
        if folder.is_dir():
            folders.add(folder.resolve())


@pytest.hookimpl(wrapper=True)
def pytest_runtest_makereport(item: pytest.Item, call: pytest.CallInfo[None]) -> Generator[None, pytest.TestReport, pytest.TestReport]:
    """A module with a skipped test: its goldens are not listed as unused."""
    report: pytest.TestReport = yield
    if report.skipped:
        item.config.stash[_NOT_RUN].add(_golden_folder(item).resolve())
    return report


def _golden_folder(item: pytest.Item) -> Path:
    path = Path(item.path)
    return path.parent / path.stem


def _golden_stem(name: str) -> str:
    """A test's name as a file name: ``test_arm[sine-0]`` → ``test_arm[sine-0]``; characters a file system
    refuses (or that would make a path) become ``_``."""
    return re.sub(r"[^A-Za-z0-9_.\[\]=+,-]", "_", name).strip(".") or "golden"


class TfrecGolden:
    """The ``tfrec_golden`` fixture: :meth:`check` a description's motion against its golden recording."""

    def __init__(self, request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> None:
        self._request = request
        self._tmp_factory = tmp_path_factory
        self._tmp: Path | None = None
        self.update = bool(request.config.getoption("tfrec_update"))

    @property
    def folder(self) -> Path:
        """Where this test module's goldens are: ``<test folder>/<test module stem>/``."""
        return _golden_folder(self._request.node)

    def golden_path(self, name: str | None = None) -> Path:
        """The golden of this test (``name``: another file name in :attr:`folder`, or a path)."""
        if name is None:
            return self.folder / f"{_golden_stem(self._request.node.name)}.mcap"
        given = Path(name)
        if given.suffix != ".mcap":
            given = given.with_name(given.name + ".mcap")
        return given if given.is_absolute() else self.folder / given

    def _workdir(self) -> Path:
        if self._tmp is None:
            self._tmp = self._tmp_factory.mktemp(_golden_stem(self._request.node.name)[:30], numbered=True)
        return self._tmp

    def _artifacts(self, stem: str) -> Path:
        chosen = self._request.config.getoption("tfrec_artifacts")
        if chosen is None:
            return self._workdir()
        folder = Path(chosen) / _golden_stem(self._request.node.name)
        folder.mkdir(parents=True, exist_ok=True)
        return folder

    def check(  # noqa: PLR0913 - `tfrec record`'s and `tfrec diff`'s keyword options
            self, description: str | os.PathLike[str], *, traj: str | os.PathLike[str] = "sine",
              duration: float | None = 2.0, seed: int = 0, rate: float | None = None,
              args: Mapping[str, str] | None = None, name: str | None = None, pos_tol: float | None = None,
              rot_tol: float | None = None, joint_tol: float | None = None,
              package_paths: tuple[str | os.PathLike[str], ...] = (),
              **options: Any) -> Path:
        """Record ``description`` along ``traj`` and compare it with the golden recording.

        Args:
            description: a ``.urdf`` or ``.xacro`` file; a relative path is looked up beside the test file,
                then in the current folder.
            traj: ``sine`` (default), ``random``, ``sweep``, ``center`` or a CSV file (looked up as
                ``description``).
            duration, seed, rate: the trajectory's seconds (None for a CSV's own), seed and samples per
                second (None: 50, or a CSV's own clock).
            args: xacro arguments.
            name: the golden's file name in the module's golden folder (default: the test's name).
            pos_tol, rot_tol, joint_tol: ``tfrec diff``'s tolerances (default: its defaults).
            package_paths: for ``$(find pkg)``.
            **options: more of ``tfrec record``'s trajectory options (``period_s``, ``amplitude``,
                ``interp``, ``hard_limits``, ``overrides``, ``frame_prefix``).

        Returns:
            The golden's path.
        """
        __tracebackhide__ = True
        from tfrec.recorder import Recipe

        golden = self.golden_path(name)
        config = self._request.config
        config.stash[_USED].add(golden.resolve())
        config.stash[_FOLDERS].add(golden.parent.resolve())
        made_in = golden.parent
        csv = os.fspath(traj) not in ("sine", "random", "sweep", "center")
        recipe = Recipe(description=self._relative(description, made_in), args=dict(args or {}),
                        traj=self._relative(traj, made_in) if csv else os.fspath(traj),
                        duration_s=None if csv else duration, rate_hz=rate, seed=seed, **options)
        fresh = self._workdir() / golden.name
        self._record(recipe, fresh, made_in, package_paths)
        if self.update:
            self._write_golden(fresh, golden)
            return golden
        if not golden.exists():
            pytest.fail(f"{golden}: no golden recording yet; make it with: pytest --tfrec-update "
                        f"{self._request.node.nodeid}", pytrace=False)
        tolerances: dict[str, Any] = {key: value for key, value in (("pos_tol", pos_tol), ("rot_tol", rot_tol),
                                                    ("joint_tol", joint_tol)) if value is not None}
        self._compare(golden, fresh, tolerances, package_paths)
        return golden

    def _relative(self, given: str | os.PathLike[str], golden_folder: Path) -> str:
        """A path as the recipe keeps it: relative to the golden's folder (so they move together)."""
        path = Path(given)
        if not path.is_absolute():
            beside_test = Path(self._request.node.path).parent / path
            path = beside_test if beside_test.exists() else Path.cwd() / path
        return Path(os.path.relpath(path.resolve(), golden_folder.resolve())).as_posix()

    @staticmethod
    def _record(recipe: Recipe, out: Path, made_in: Path, package_paths: tuple[str | os.PathLike[str], ...]) -> None:
        __tracebackhide__ = True
        import warnings

        from tfrec.errors import TfrecError
        from tfrec.recorder import record_recipe

        problem = None
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # the recording's own warnings are not the test's failure
                record_recipe(recipe, out, beside=made_in, force=True, package_paths=package_paths)
        except TfrecError as err:
            problem = str(err)
        if problem is not None:  # outside the except block: no "during handling" chain in the report
            pytest.fail(f"tfrec_golden: {problem}", pytrace=False)

    def _write_golden(self, fresh: Path, golden: Path) -> None:
        from tfrec._atomic import AtomicOutputs
        from tfrec.formats.kinds import MCAP

        golden.parent.mkdir(parents=True, exist_ok=True)
        with AtomicOutputs(replace=True) as outputs:
            temp = outputs.path(golden, kind=MCAP)
            temp.write_bytes(fresh.read_bytes())
            outputs.commit()
        self._request.node.user_properties.append(("tfrec_golden_written", os.fspath(golden)))
        self._request.config.stash[_WRITTEN].append(golden)

    def _compare(self, golden: Path, fresh: Path, tolerances: dict[str, Any],
                 package_paths: tuple[str | os.PathLike[str], ...]) -> None:
        __tracebackhide__ = True
        from tfrec.diff.compare import compare

        report = compare(golden, fresh, whole=True, **tolerances)  # whole: the error plot draws every sample
        if report.equal:
            return
        artifacts = self._write_artifacts(golden, fresh, report, tolerances, package_paths)
        lines = [f"{golden}: the recording differs from its golden", report.to_text().rstrip("\n")]
        lines += [f"  artefact: {path}" for path in artifacts]
        lines.append(f"  (if the change is meant: pytest --tfrec-update {self._request.node.nodeid})")
        pytest.fail("\n".join(lines), pytrace=False)

    def _write_artifacts(self, golden: Path, fresh: Path, report: Any, tolerances: dict[str, Any],
                         package_paths: tuple[str | os.PathLike[str], ...]) -> list[Path]:
        """The ghost overlay (the golden solid, coloured by its error; the new one translucent) and the error
        plot, beside the test's output."""
        import warnings

        from tfrec.diff.motion import compare_motion
        from tfrec.diff.overlay import write_overlay
        from tfrec.plots import plot_diff

        folder = self._artifacts(golden.stem)
        overlay, plot = folder / f"{golden.stem}.diff.rrd", folder / f"{golden.stem}.diff.png"
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            comparison = compare_motion(os.fspath(golden), os.fspath(fresh), package_paths=package_paths, **tolerances)
            write_overlay(comparison, overlay, force=True, package_paths=package_paths)
            plot_diff(report, plot, force=True)
        return [overlay, plot]


@pytest.fixture
def tfrec_golden(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> Iterator[TfrecGolden]:
    """Compare a robot description's motion with a golden recording (``check``); ``--tfrec-update`` writes it."""
    yield TfrecGolden(request, tmp_path_factory)


def pytest_terminal_summary(terminalreporter: Any, exitstatus: int, config: pytest.Config) -> None:
    """List the goldens no test used this time, in the golden folders of the test modules that ran whole."""
    if _USED not in config.stash:
        return
    used, not_run = config.stash[_USED], config.stash[_NOT_RUN]
    unused = [path for folder in sorted(config.stash[_FOLDERS] - not_run) for path in sorted(folder.glob("*.mcap"))
              if path.resolve() not in used]
    written = config.stash[_WRITTEN]
    if written:
        terminalreporter.section("tfrec: goldens written (--tfrec-update)")
        for path in written:
            terminalreporter.write_line(os.fspath(path))
    if unused:
        terminalreporter.section("tfrec: goldens no test used")
        for path in unused:
            terminalreporter.write_line(f"{path}  (delete it if no test needs it)")
