"""``REV:PATH`` inputs of ``tfrec diff``: a file as it was in a git revision, with everything around it.

``tfrec diff HEAD~1:robots/arm.xacro robots/arm.xacro`` compares a description with itself one commit ago.
The revision's whole tree is written by ``git archive`` into a temporary folder — not checked out: the work
tree, the index and HEAD are untouched — so that the files it includes, its meshes and the packages of its
workspace are the revision's too. As in git, ``PATH`` is relative to the repository's top folder, or to the
current folder when it starts with ``./`` or ``../``. Submodules are not in ``git archive``'s output.
"""

from __future__ import annotations

import contextlib
import os
import subprocess
import tarfile
import tempfile
from collections.abc import Sequence
from pathlib import Path
from types import TracebackType
from typing import final

from tfrec.errors import DiffError

__all__ = ["Revisions", "is_revision_path", "split_revision_path"]

_GIT_TIMEOUT_S = 300


def split_revision_path(token: str) -> tuple[str, str] | None:
    """``REV:PATH`` → (REV, PATH) when ``token`` names no existing file and has that form; else None."""
    if os.path.lexists(token) or ":" not in token or ":=" in token:
        return None
    rev, _, path = token.partition(":")
    if not rev or not path or rev.startswith("-"):
        return None
    return rev, path


def is_revision_path(token: str) -> bool:
    return split_revision_path(token) is not None


def _git(args: Sequence[str], *, cwd: str | os.PathLike[str], what: str, otherwise: str | None = None) -> bytes:
    """Run git; its failure is a :class:`DiffError` naming ``what`` (with ``otherwise``, or git's last line)."""
    try:
        done = subprocess.run(["git", *args], cwd=cwd, capture_output=True, timeout=_GIT_TIMEOUT_S, check=False)
    except FileNotFoundError:
        raise DiffError(f"{what}: a REV:PATH input needs git, which is not installed") from None
    except subprocess.TimeoutExpired:
        raise DiffError(f"{what}: git did not answer within {_GIT_TIMEOUT_S} s") from None
    if done.returncode != 0:
        message = done.stderr.decode("utf-8", "replace").strip().splitlines()
        raise DiffError(f"{what}: {otherwise or (message[-1] if message else f'git {args[0]} failed')}")
    return done.stdout


@final
class Revisions:
    """The ``REV:PATH`` inputs of one diff, each written into a temporary folder; a context manager that
    removes them.

    :meth:`path` gives the file to read for an input (the input itself when it is no ``REV:PATH``);
    :meth:`shown` puts the ``REV:PATH`` names back into a report's text.
    """

    def __init__(self) -> None:
        self._stack = contextlib.ExitStack()
        self._trees: dict[str, Path] = {}
        self._named: dict[str, str] = {}  # temporary path → REV:PATH

    def __enter__(self) -> Revisions:
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 traceback: TracebackType | None) -> None:
        self._stack.close()

    def path(self, token: str) -> str:
        """The file an input names: ``REV:PATH`` taken from the revision, anything else as it is.

        Raises:
            DiffError: not a git repository, an unknown revision, or a path the revision does not hold.
        """
        parts = split_revision_path(token)
        if parts is None:
            return token
        rev, path = parts
        top = _git(["rev-parse", "--show-toplevel"], cwd=".", what=token).decode().strip()
        commit = _git(["rev-parse", "--verify", "--quiet", "--end-of-options", f"{rev}^{{commit}}"], cwd=top,
                      what=token, otherwise=f"no revision '{rev}' in the repository {top}").decode().strip()
        if path.startswith(("./", "../")):
            prefix = _git(["rev-parse", "--show-prefix"], cwd=".", what=token).decode().strip()
            path = os.path.normpath(os.path.join(prefix, path))
        tree = self._tree(commit, top, token)
        found = tree / path
        if not found.resolve().is_relative_to(tree.resolve()) or not os.path.lexists(found):
            raise DiffError(f"{token}: revision {rev} ({commit[:12]}) has no {path}")
        self._named[os.fspath(found)] = token
        return os.fspath(found)

    def _tree(self, commit: str, top: str, token: str) -> Path:
        """The revision's tree, written once per commit by ``git archive`` (no checkout)."""
        if commit in self._trees:
            return self._trees[commit]
        folder = Path(self._stack.enter_context(tempfile.TemporaryDirectory(prefix="tfrec-rev-")))
        archive = folder / "tree.tar"
        _git(["archive", "--format=tar", "-o", os.fspath(archive), commit], cwd=top, what=token)
        tree = folder / "tree"
        tree.mkdir()
        try:
            with tarfile.open(archive) as tar:
                tar.extractall(tree, filter="data")  # no absolute paths, links out of the tree, devices
        except (tarfile.TarError, OSError) as err:
            raise DiffError(f"{token}: cannot unpack the revision's files: {err}") from err
        finally:
            with contextlib.suppress(OSError):
                archive.unlink()
        self._trees[commit] = tree
        return tree

    def shown(self, text: str) -> str:
        """``text`` with each temporary path of a ``REV:PATH`` input given back its name."""
        for temp, token in sorted(self._named.items(), key=lambda item: -len(item[0])):
            text = text.replace(temp, token)
        return text
