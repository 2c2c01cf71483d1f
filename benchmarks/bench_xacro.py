"""xacro expansion: tfrec's (sandbox, legacy-dialect check, element origins for messages) against stock
PyPI xacro on the same files, in the same process.

- stock: ``xacro.parse`` + ``xacro.process_doc`` + ``toprettyxml``, with only ``$(find)`` pointed at the
  packages (what ROS 2's xacro does);
- tfrec: ``tfrec.description.xacro.expand_xacro`` — the same xacro inside tfrec's sandbox, with the
  hooks that tell the Kinetic-era dialect apart and note where each element was written. A file
  written in that dialect (robots/mbot.xacro) is expanded twice: once as PyPI xacro would, which
  meets the dialect, then in it.

Process CPU time, best of 20 runs each, after one warm-up (the machine is shared: CPU time, not wall
time). Run from the repository root (../shared/corpus beside it):

    .venv/bin/python benchmarks/bench_xacro.py
"""

from __future__ import annotations

import contextlib
import io
import os
import time
import warnings
from collections.abc import Callable
from pathlib import Path

from _common import machine

from tfrec.description.packages import PackageFinder
from tfrec.description.xacro import _LOCK, _patched_xacro, expand_xacro

REPO = Path(__file__).resolve().parents[1]
CORPUS = next((p / "shared" / "corpus" for p in REPO.parents if (p / "shared" / "corpus").is_dir()), None)
ROBOTS: list[tuple[str, Path, dict[str, str]]] = [("robots/mbot.xacro (Kinetic-era dialect)", REPO / "robots/mbot.xacro", {}),
                                                  ("robots/marm.xacro", REPO / "robots/marm.xacro", {})]
if CORPUS is not None:
    ROBOTS += [("panda.urdf.xacro hand:=true", CORPUS / "franka_description/robots/panda/panda.urdf.xacro",
                {"hand": "true"}),
               ("ur5.xacro", CORPUS / "ur_description/urdf/ur5.xacro", {}),
               ("robotiq_2f_85_gripper.urdf.xacro", CORPUS / "robotiq_description/urdf/robotiq_2f_85_gripper.urdf.xacro",
                {})]


def stock(path: Path, args: dict[str, str], paths: list[Path]) -> str:
    finder = PackageFinder(paths, near=path)
    with _LOCK, _patched_xacro(finder) as xacro, contextlib.redirect_stderr(io.StringIO()):
        xacro.init_stacks(os.fspath(path))
        doc = xacro.parse(None, os.fspath(path))
        xacro.process_doc(doc, mappings=dict(args))
        return str(doc.toprettyxml(indent="  "))


def tfrec(path: Path, args: dict[str, str], paths: list[Path]) -> str:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # mbot's legacy-dialect warning
        return expand_xacro(path, args=args, finder=PackageFinder(paths, near=path), package_paths=paths)


def best_cpu(repeat: int, run: Callable[[], object]) -> float:
    """CPU seconds of the fastest of ``repeat`` calls of ``run``."""
    best = float("inf")
    for _ in range(repeat):
        start = time.process_time()
        run()
        best = min(best, time.process_time() - start)
    return best


def main() -> None:
    print(machine("xacro"))
    paths = [REPO / "robots", *([CORPUS] if CORPUS is not None else [])]
    for label, path, args in ROBOTS:
        for run in (stock, tfrec):
            run(path, args, paths)
        times = {run.__name__: best_cpu(20, lambda run=run, path=path, args=args: run(path, args, paths))
                 for run in (stock, tfrec)}
        print(f"{label}: stock xacro {times['stock'] * 1000:.1f} ms, tfrec {times['tfrec'] * 1000:.1f} ms "
              f"(x{times['tfrec'] / times['stock']:.2f})")


if __name__ == "__main__":
    main()
