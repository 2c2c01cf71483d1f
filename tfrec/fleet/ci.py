"""Reports for CI of ``tfrec check`` and ``tfrec diff``: JUnit XML, GitHub workflow annotations, a Markdown summary.

One :class:`Case` per recording (``check``), per pair (``diff DIR_A DIR_B``) or for the one comparison
(``diff A B``), with its findings; made from fleet report rows (:func:`cases_from_rows`) or from a diff report
(:func:`case_from_diff`). Then:

- :func:`junit_xml`: ``<testsuites><testsuite><testcase>``, a finding a ``<failure>``, a recording that could
  not be read an ``<error>`` — the schema GitLab's and GitHub's test reporters read (docs/ci.md);
- :func:`github_annotations`: ``::error file=…,line=…,title=…::…`` lines; a finding about an element of a
  description file (a joint, a link) points at its line (:func:`element_line`);
- :func:`markdown_summary`: verdicts, the worst errors and the artefacts, for ``$GITHUB_STEP_SUMMARY``.

Files are written atomically, and replaced (``force``) only when they are of their kind (:data:`JUNIT`,
:data:`SUMMARY`).
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any
from xml.etree import ElementTree

from tfrec._outputs import FileKind
from tfrec.errors import printable
from tfrec.fleet.row import ERROR, FAIL, PASS, SUMMARY, Row

__all__ = [
    "JUNIT",
    "SUMMARY_MD",
    "Case",
    "CaseFinding",
    "case_from_diff",
    "cases_from_rows",
    "element_line",
    "github_annotations",
    "joint_line_of_child",
    "junit_xml",
    "markdown_summary",
    "write_ci_outputs",
]


def _junit_test(path: Path, head: bytes) -> str | None:
    text = head.decode("utf-8", "replace").lstrip("\ufeff \t\r\n")
    return None if text.startswith("<") and "<testsuites" in text else "it is not JUnit XML (no <testsuites>)"


_MARK = "<!-- tfrec summary -->"


def _summary_test(path: Path, head: bytes) -> str | None:
    return None if head.decode("utf-8", "replace").startswith(_MARK) else f"its first line is not {_MARK}"


JUNIT = FileKind("a JUnit XML report", test=_junit_test)
"""``--junit``: an existing file is replaced only when it is JUnit XML."""
SUMMARY_MD = FileKind("a tfrec Markdown summary", empty=True, test=_summary_test)
"""``--summary``: an existing file is replaced only when tfrec wrote it (its first line is a marker comment), or when
it is empty (``$GITHUB_STEP_SUMMARY``, which GitHub creates empty for each step)."""


@dataclass(frozen=True, slots=True)
class CaseFinding:
    """One finding of a case: what found it, on what, the readable line, where it belongs (a file and line)."""

    check: str
    what: str
    detail: str
    file: str = ""
    line: int | None = None
    value: float | None = None
    unit: str = ""
    time_s: float | None = None


@dataclass(frozen=True, slots=True)
class Case:
    """One test case: a recording, a pair or a comparison, its verdict (pass, fail, error) and findings."""

    name: str
    verdict: str
    detail: str
    findings: tuple[CaseFinding, ...] = ()
    file: str = ""
    seconds: float = 0.0
    largest: tuple[str, float, str] | None = None
    """(what, value, unit) of the worst error, for the summary."""
    artefacts: tuple[str, ...] = field(default=())


# -- cases -------------------------------------------------------------------------------------------


def cases_from_rows(rows: Iterable[Row | Mapping[str, Any]], *, description: str | None = None) -> list[Case]:
    """One case per recording (or pair) of a fleet run's rows, in the order of their summary rows.

    Args:
        rows: :class:`Row` objects or their dicts (a resumed report's).
        description: the description file the recordings were checked against (``check --robot``): findings
            about a frame point at its element's line.
    """
    heads: dict[str, Row] = {}
    found: dict[str, list[Row]] = {}
    for given in rows:
        row = given if isinstance(given, Row) else Row(**{k: v for k, v in given.items() if k in _ROW_FIELDS})
        if row.check == SUMMARY:
            heads[row.file] = row
        else:
            found.setdefault(row.file, []).append(row)
    cases = []
    for file, head in heads.items():
        findings = tuple(_finding_of_row(row, description) for row in found.get(file, ()))
        largest = (head.frame, head.max_error, head.unit) if head.max_error is not None else None
        cases.append(Case(name=file, verdict=head.verdict, detail=head.detail, findings=findings, file=file,
                          seconds=head.elapsed_s or 0.0, largest=largest))
    return cases


_ROW_FIELDS = frozenset(f.name for f in fields(Row))


def _finding_of_row(row: Row, description: str | None) -> CaseFinding:
    line = None
    file = row.file
    if description is not None and row.frame:
        child = row.frame.rpartition(" → ")[2]
        line = joint_line_of_child(description, child) or element_line(description, "link", child) or element_line(
            description, "joint", row.frame)
        if line is not None:
            file = description
    return CaseFinding(row.check, row.frame or row.topic, row.detail, file=file, line=line, value=row.max_error,
                       unit=row.unit, time_s=row.first_exceed_s)


_ELEMENT = re.compile(r"^(?P<kind>joint|link|material|transmission) '(?P<name>.*)'$")


def case_from_diff(report: Any, *, a: str, b: str, files: Sequence[str | None] = (None, None),
                   artefacts: Sequence[str] = ()) -> Case:
    """The one case of ``tfrec diff A B``, from its :class:`~tfrec.diff.DiffReport` or
    :class:`~tfrec.diff.DescriptionDiffReport`.

    Args:
        a, b: the inputs as given (the case's name is ``A vs B``).
        files: the description file of each side, when it is one: a change of an element (``joint 'elbow'``)
            points at its line in B's file (A's, for an element B no longer has).
        artefacts: files written beside (the overlay, the plot), for the summary.
    """
    findings = []
    for difference in report.differences:
        file, line = b, None
        match = _ELEMENT.match(difference.what)
        if match is not None:
            for side in (files[1], files[0]):
                if side is not None:
                    line = element_line(side, match["kind"], match["name"])
                    if line is not None:
                        file = side
                        break
        findings.append(CaseFinding(difference.kind, difference.what, difference.detail, file=file, line=line,
                                    value=difference.value, time_s=difference.time_s))
    largest = None
    for key, unit in (("translation", "m"), ("position", "m"), ("rotation", "rad")):
        worst = report.largest.get(key)
        if worst is not None and worst.value:
            largest = (worst.what, float(worst.value), unit)
            break
    return Case(name=f"{a} vs {b}", verdict=PASS if report.equal else FAIL, detail=report.verdict,
                findings=tuple(findings), file=b, largest=largest, artefacts=tuple(artefacts))


def element_line(path: str | os.PathLike[str], kind: str, name: str) -> int | None:
    """The line (from 1) where ``<kind name="name"`` begins in a description file; None when the file cannot
    be read or does not hold it literally (an element a xacro macro makes with a computed name)."""
    text = _text_of(path)
    if text is None:
        return None
    pattern = re.compile(rf"<\s*(?:xacro:)?{re.escape(kind)}\b[^>]*?\bname\s*=\s*([\"']){re.escape(name)}\1")
    match = pattern.search(text)
    return None if match is None else text.count("\n", 0, match.start()) + 1


def joint_line_of_child(path: str | os.PathLike[str], child: str) -> int | None:
    """The line (from 1) of the ``<joint>`` whose ``<child link="child"/>`` places a frame: where a frame's pose is
    written; None when the file does not hold it literally."""
    text = _text_of(path)
    if text is None:
        return None
    wanted = re.compile(rf"<\s*child\b[^>]*\blink\s*=\s*([\"']){re.escape(child)}\1")
    for match in _JOINT.finditer(text):
        end = text.find("</joint>", match.end())
        if wanted.search(text, match.end(), len(text) if end < 0 else end):
            return text.count("\n", 0, match.start()) + 1
    return None


_JOINT = re.compile(r"<\s*joint\b[^>]*>")


def _text_of(path: str | os.PathLike[str]) -> str | None:
    try:
        with open(path, "rb") as stream:
            return stream.read(16 << 20).decode("utf-8", "replace")
    except OSError:
        return None


# -- JUnit XML -----------------------------------------------------------------------------------------


_XML_ILLEGAL = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ud800-\udfff\ufffe\uffff]")


def _xml_text(text: str) -> str:
    """Text XML 1.0 can hold: characters it forbids (a control character in a file name) as ``\\xNN``."""
    return _XML_ILLEGAL.sub(lambda m: f"\\x{ord(m.group()):02x}", text)


def junit_xml(cases: Sequence[Case], *, suite: str, timestamp: str | None = None, hostname: str | None = None) -> bytes:
    """The cases as JUnit XML: one ``<testsuite name=suite>``, one ``<testcase>`` per case; a failing case has one
    ``<failure>`` (its findings, one per line), a case that could not be checked an ``<error>``.

    The suite carries every attribute and element the strictest JUnit schemas ask for (Ant's: ``timestamp``,
    ``hostname``, ``id``, ``package``, ``<properties>``, ``<system-out>``, ``<system-err>``); ``timestamp`` (ISO 8601,
    UTC, no zone, as they want it) and ``hostname`` default to now and this machine."""
    import datetime
    import socket

    failures = sum(case.verdict == FAIL for case in cases)
    errors = sum(case.verdict == ERROR for case in cases)
    seconds = f"{sum(case.seconds for case in cases):.3f}"
    when = timestamp or datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%S")
    root = ElementTree.Element("testsuites", name="tfrec", tests=str(len(cases)), failures=str(failures),
                               errors=str(errors), time=seconds)
    element = ElementTree.SubElement(root, "testsuite", name=suite, tests=str(len(cases)), failures=str(failures),
                                     errors=str(errors), skipped="0", time=seconds, timestamp=when,
                                     hostname=_xml_text(hostname or socket.gethostname() or "localhost"), id="0",
                                     package="tfrec")
    ElementTree.SubElement(element, "properties")
    for case in cases:
        test = ElementTree.SubElement(element, "testcase", classname=_xml_text(f"tfrec.{suite}"),
                                      name=_xml_text(case.name), time=f"{case.seconds:.3f}")
        if case.verdict == PASS:
            continue
        tag = "error" if case.verdict == ERROR else "failure"
        failure = ElementTree.SubElement(test, tag, message=_xml_text(case.detail), type=tag)
        lines = [case.detail] + [_finding_text(finding) for finding in case.findings]
        failure.text = _xml_text("\n".join(lines))
    ElementTree.SubElement(element, "system-out")
    ElementTree.SubElement(element, "system-err")
    ElementTree.indent(root)
    body: bytes = ElementTree.tostring(root, encoding="unicode").encode()
    return b'<?xml version="1.0" encoding="UTF-8"?>\n' + body + b"\n"


def _finding_text(finding: CaseFinding) -> str:
    where = f"{finding.file}:{finding.line}: " if finding.line is not None else ""
    return f"{where}{finding.check}: {finding.detail}"


# -- GitHub annotations --------------------------------------------------------------------------------


def _escape_data(text: str) -> str:
    return text.replace("%", "%25").replace("\r", "%0D").replace("\n", "%0A")


def _escape_property(text: str) -> str:
    return _escape_data(text).replace(":", "%3A").replace(",", "%2C")


def github_annotations(cases: Sequence[Case]) -> list[str]:
    """GitHub Actions workflow commands, one ``::error`` per finding (per case without findings that fails); a
    finding about an element of a description file names its file and line."""
    lines = []
    for case in cases:
        if case.verdict == PASS:
            continue
        findings = case.findings or (CaseFinding(case.verdict, "", case.detail, file=case.file),)
        for finding in findings:
            props = [f"file={_escape_property(finding.file or case.file)}"]
            if finding.line is not None:
                props.append(f"line={finding.line}")
            props.append(f"title={_escape_property(f'tfrec: {finding.check}' + (f' {finding.what}' if finding.what else ''))}")
            lines.append(f"::error {','.join(props)}::{_escape_data(finding.detail)}")
    return lines


# -- Markdown summary ----------------------------------------------------------------------------------


_ICON: dict[str, str] = {PASS: "✅ pass", FAIL: "❌ fail", ERROR: "⚠️ error"}


def _cell(text: str) -> str:
    """Text for a Markdown table cell: escaped as the terminal shows it (:func:`tfrec.errors.printable`: control
    characters, a file name's bytes that are not UTF-8), no ``|`` or backquote that would end the cell or the code."""
    return printable(text.replace("\n", " ")).replace("|", "\\|").replace("`", "'")


def markdown_summary(cases: Sequence[Case], *, title: str, artefacts: Sequence[str] = ()) -> str:
    """A Markdown summary (for ``$GITHUB_STEP_SUMMARY``): the counts, a table of verdicts (failing first), the worst
    errors and links to the artefacts."""
    counts = {verdict: sum(case.verdict == verdict for case in cases) for verdict in (PASS, FAIL, ERROR)}
    lines = [_MARK, f"## {title}", "",
             f"**{len(cases)}** checked: {counts[PASS]} pass, {counts[FAIL]} fail, {counts[ERROR]} error", "",
             "| verdict | what | detail |", "|---|---|---|"]
    order = sorted(cases, key=lambda case: (case.verdict == PASS, case.verdict != ERROR))
    lines += [f"| {_ICON.get(case.verdict, case.verdict)} | `{_cell(case.name)}` | {_cell(case.detail)} |" for case in order]
    worst = sorted((case for case in cases if case.largest is not None and math.isfinite(case.largest[1])),
                   key=lambda case: -case.largest[1] if case.largest else 0.0)[:10]
    if worst:
        lines += ["", "### Worst errors", "", "| what | where | error |", "|---|---|---|"]
        lines += [f"| `{_cell(case.name)}` | {_cell(case.largest[0])} | {case.largest[1]:.6g} {case.largest[2]} |"
                  for case in worst if case.largest is not None]
    failing = [finding for case in order if case.verdict != PASS for finding in case.findings][:50]
    if failing:
        lines += ["", "### Findings", ""]
        lines += [f"- {_cell(_finding_text(finding))}" for finding in failing]
    shown = [*artefacts, *(path for case in cases for path in case.artefacts)]
    if shown:
        lines += ["", "### Artefacts", ""] + [f"- [{_cell(path)}]({_cell(path).replace(' ', '%20')})" for path in shown]
    return "\n".join(lines) + "\n"


# -- files ---------------------------------------------------------------------------------------------


def write_ci_outputs(cases: Sequence[Case], *, suite: str, title: str, junit: str | os.PathLike[str] | None,
                     summary: str | os.PathLike[str] | None, force: bool, artefacts: Sequence[str] = ()) -> None:
    """Write ``--junit`` and ``--summary`` together, atomically (checked before with
    :func:`tfrec._outputs.check_outputs`)."""
    from tfrec._atomic import AtomicOutputs

    with AtomicOutputs(replace=force) as outputs:
        if junit is not None:
            outputs.path(Path(junit), kind=JUNIT).write_bytes(junit_xml(cases, suite=suite))
        if summary is not None:
            outputs.path(Path(summary), kind=SUMMARY_MD).write_text(
                markdown_summary(cases, title=title, artefacts=artefacts), encoding="utf-8")
        outputs.commit()
