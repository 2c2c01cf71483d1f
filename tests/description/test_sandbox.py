"""The xacro sandbox: expressions run no code, files outside the description's places are not read,
expansion is bounded, malformed elements and other encodings give one line — and every real
description expands exactly as stock xacro expands it.

``expand`` below is how ``tfrec.description.xacro.expand_xacro`` is meant to use the sandbox.
"""

from __future__ import annotations

import contextlib
import io
import os
import time
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path

import pytest

from tests import conftest
from tests.conftest import CORPUS_ABSENT, REPO, ROBOTS
from tfrec.description._sandbox import (
    SandboxLimits,
    SandboxRefusal,
    decode_xml,
    describe_xacro_failure,
    parse_xml,
    xacro_sandbox,
)
from tfrec.description.packages import PackageFinder
from tfrec.description.xacro import _LOCK, _patched_xacro
from tfrec.errors import DescriptionError, display_path, one_line

XMLNS = 'xmlns:xacro="http://www.ros.org/wiki/xacro"'
CORPUS = next((p for p in (conftest.CORPUS, REPO.parents[1] / "shared" / "corpus") if p.is_dir()), conftest.CORPUS)
"""../shared/corpus, or ../../shared/corpus from a git worktree in a folder of worktrees."""
PASSWD = Path("/etc/passwd")
DEFAULT_LIMITS = SandboxLimits()


# ---- the harness: expand_xacro with the sandbox, and stock xacro as it runs today -------------


def expand(
    path: Path,
    args: Mapping[str, str] | None = None,
    *,
    package_paths: Sequence[Path] = (),
    allow_paths: Sequence[Path] = (),
    limits: SandboxLimits = DEFAULT_LIMITS,
    environ: Mapping[str, str] | None = None,
) -> str:
    """Expand ``path`` in the sandbox; every failure is one DescriptionError line."""
    finder = PackageFinder(package_paths, near=path, environ=environ or {})
    filename = os.fspath(path)
    with _LOCK, xacro_sandbox(path, finder=finder, package_paths=package_paths, allow_paths=allow_paths,
                              limits=limits), _patched_xacro(finder) as xacro:
        try:
            with contextlib.redirect_stderr(io.StringIO()):
                xacro.init_stacks(filename)
                doc = xacro.parse(None, filename)
                xacro.process_doc(doc, mappings=dict(args or {}))
        except RecursionError:
            raise DescriptionError(f"{display_path(filename)}: xacro recursion too deep") from None
        except (xacro.XacroException, DescriptionError, RuntimeError, NameError, TypeError, ValueError,
                SyntaxError, KeyError) as err:
            message = describe_xacro_failure(err, filename=filename, filestack=xacro.filestack)
            raise DescriptionError(message or f"{display_path(filename)}: xacro: {one_line(str(err))}") from err
        return str(doc.toprettyxml(indent="  "))


def expand_stock(path: Path, args: Mapping[str, str] | None = None, *, package_paths: Sequence[Path] = ()) -> str:
    """Expand ``path`` with stock xacro (its $(find) through ``finder``; no sandbox, no legacy dialect)."""
    finder = PackageFinder(package_paths, near=path, environ={})
    filename = os.fspath(path)
    with _LOCK, _patched_xacro(finder) as xacro, contextlib.redirect_stderr(io.StringIO()):
        xacro.init_stacks(filename)
        doc = xacro.parse(None, filename)
        xacro.process_doc(doc, mappings=dict(args or {}))
        return str(doc.toprettyxml(indent="  "))


def robot(body: str) -> str:
    return f'<?xml version="1.0"?>\n<robot {XMLNS} name="r">\n{body}\n</robot>\n'


def write(path: Path, text: str) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")
    return path


def refused(path: Path, pattern: str, **kwargs: object) -> str:
    """Expand and expect one DescriptionError line naming ``path`` and matching ``pattern``."""
    with pytest.raises(DescriptionError, match=pattern) as caught:
        expand(path, **kwargs)  # type: ignore[arg-type]
    message = str(caught.value)
    assert "\n" not in message
    assert message.startswith(display_path(path)), message
    assert "root:" not in message  # no line of /etc/passwd, ever
    return message


# ---- every real description expands as stock xacro expands it ----------------------------------


def _corpus_entries() -> list[tuple[str, dict[str, str]]]:
    entries: list[tuple[str, dict[str, str]]] = [
        ("urdf_tutorial/urdf/08-macroed.urdf.xacro", {}),
        *[(f"urdf_tutorial/urdf/{p.name}", {}) for p in sorted((CORPUS / "urdf_tutorial/urdf").glob("0*.urdf"))],
        ("turtlebot3_description/urdf/turtlebot3_burger.urdf.xacro", {}),
        ("turtlebot3_description/urdf/turtlebot3_waffle.urdf.xacro", {}),
        ("turtlebot3_description/urdf/turtlebot3_waffle_pi.urdf.xacro", {}),
        *[(f"ur_description/urdf/{p.name}", {}) for p in sorted((CORPUS / "ur_description/urdf").glob("ur*.xacro"))
          if p.name != "ur.xacro"],
        ("franka_description/robots/panda/panda.urdf.xacro", {"hand": "true"}),
        ("franka_description/robots/panda/panda.urdf.xacro", {}),
        ("robotiq_description/urdf/robotiq_2f_85_gripper.urdf.xacro", {}),
    ]
    config = CORPUS / "ur_description/config/ur10e"
    entries.append(("ur_description/urdf/ur.xacro", {
        "robot_model": "ur10e",
        "joint_limit_params": str(config / "joint_limits.yaml"),
        "kinematics_params": str(config / "default_kinematics.yaml"),
        "physical_params": str(config / "physical_parameters.yaml"),
        "visual_params": str(config / "visual_parameters.yaml"),
    }))
    return entries


CORPUS_ENTRIES = _corpus_entries() if CORPUS.is_dir() else []


@pytest.mark.skipif(not CORPUS.is_dir(), reason=CORPUS_ABSENT)
@pytest.mark.parametrize("entry, args", CORPUS_ENTRIES, ids=[f"{e}{' ' if a else ''}{','.join(a)}" for e, a in
                                                              CORPUS_ENTRIES])
def test_corpus_expands_as_stock_xacro(entry: str, args: dict[str, str]) -> None:
    path = CORPUS / entry
    assert expand(path, args, package_paths=[CORPUS]) == expand_stock(path, args, package_paths=[CORPUS])


@pytest.mark.skipif(not CORPUS.is_dir(), reason=CORPUS_ABSENT)
def test_corpus_found_through_siblings_without_package_paths() -> None:
    """The panda finds franka_description as a sibling package: readable without --package-path."""
    path = CORPUS / "franka_description/robots/panda/panda.urdf.xacro"
    assert expand(path, {"hand": "true"}) == expand_stock(path, {"hand": "true"})


@pytest.mark.parametrize("name", sorted(p.name for p in ROBOTS.glob("*.xacro")))
def test_repository_robots_expand_as_stock_xacro(name: str) -> None:
    assert expand(ROBOTS / name) == expand_stock(ROBOTS / name)


def test_legitimate_expressions_keep_working(tmp_path: Path) -> None:
    write(tmp_path / "config.yaml", "arm:\n  type: revolute\n  limits: [1.5, -1.5]\n  names: [a, b]\n"
                                     "angle: !degrees 90\nlength: !millimeters 250\n")
    path = write(tmp_path / "exprs.xacro", robot("""
  <xacro:property name="cfg" value="${xacro.load_yaml('config.yaml')}"/>
  <xacro:property name="n" value="3"/>
  <xacro:arg name="prefix" default="left_"/>
  <xacro:property name="template" value="{}_{:02d}"/>
  <xacro:property name="named" value="{name}!"/>
  <xacro:property name="with_arg" value="arg('prefix') + 'x'"/>
  <link name="$(arg prefix)base" a="${cfg.arm.type}" b="${cfg['arm']['limits'][0] * 2}" c="${cfg.angle}"
        d="${cfg.length}" e="${[x * 2 for x in python.range(n)]}" f="${'x'.upper()}"
        g="${'%s-%03d' % ('j', n)}" h="$(eval f'{pi:.4f}')" i="${template.format('link', n)}"
        j="${(lambda v: v + 1)(n)}" k="${dict((k, len(k)) for k in cfg.arm.names)}" l="${sorted([3, 1, 2])}"
        m="${radians(180)}" o="${','.join(str(i) for i in python.range(n))}" p="${math.sqrt(16)}"
        q="${max(cfg.arm.limits)}" r="${2 ** 10}" s="${'a-b'.replace('-', '_')}" t="${cfg.arm.get('type')}"
        u="$(eval 1 + 2)" v="$(eval ${with_arg})" w="${'x' * 3}" y="${list(map(python.abs, [-1, 2]))}"
        z="${named.format_map(dict(name='z'))}" zz="${[n, [n, n]] + [n]}"/>
"""))
    urdf = expand(path)
    assert urdf == expand_stock(path)
    for attribute in ('a="revolute"', 'b="3.0"', 'c="1.5707963267948966"', 'd="0.25"', 'e="[0, 2, 4]"',
                      'g="j-003"', 'h="3.1416"', 'i="link_03"', 'j="4"', 'l="[1, 2, 3]"', 'o="0,1,2"',
                      'r="1024"', 's="a_b"', 'u="3"', 'v="left_x"', 'w="xxx"', 'y="[1, 2]"', 'z="z!"',
                      "k=\"{'a': 1, 'b': 1}\"", 'zz="[3, [3, 3], 3]"'):
        assert attribute in urdf


# ---- expressions: the escape shapes run no code ----------------------------------------------


ESCAPES = {
    "lambda": "${(lambda: ().__class__)()}",
    "comprehension": "${[c for c in ().__class__.__bases__]}",
    "nested comprehension": "${[[s for s in b.__subclasses__()] for b in [().__class__.__base__]]}",
    "generator": "${list(c for c in ().__class__.__mro__)}",
    "generator frame": "${[g for g in [(x for x in [1])]][0].gi_frame}",
    "getattr": "${getattr((), '__cla' + 'ss__')}",
    "python.getattr": "${python.getattr((), 'x')}",
    "python.type": "${python.type(1)}",
    "python.vars": "${python.vars()}",
    "python['vars']": "${python['vars'](xacro)}",
    "class mro": "${int.mro()}",
    "format attribute": "${fmt.format(1)}",
    "format item": "${item.format(xacro)}",
    "format_map": "${fmt.format_map(xacro)}",
    "format reference": "${list(map(fmt.format, [1]))}",
    "unbound str.format": "${python.str.format(fmt, 1)}",
    "eval import": "$(eval ${imported})",
    "eval builtins": "$(eval ${payload})",
    "eval eval": "$(eval ${evaluated})",
    "eval getattr": "$(eval ${reach})",
    "dunder builtins": "${__builtins__}",
    "guard name": "${__tfrec__}",
}


@pytest.mark.parametrize("shape", list(ESCAPES))
def test_escape_shapes_run_no_code(tmp_path: Path, shape: str) -> None:
    marker = tmp_path / "MARKER"
    payload = f"open('{marker}', 'w').close()"
    path = write(tmp_path / "escape.xacro", robot(f"""
  <xacro:property name="fmt" value="{{0.__class__}}"/>
  <xacro:property name="item" value="{{0[root]}}"/>
  <xacro:property name="payload" value="{payload}"/>
  <xacro:property name="evaluated" value="eval(&quot;{payload}&quot;)"/>
  <xacro:property name="reach" value="getattr(().__class__, 'mro')"/>
  <xacro:property name="imported" value="__import__('os').system('touch {marker}')"/>
  <link name="{ESCAPES[shape].replace('MARKER', str(marker))}"/>"""))
    refused(path, r"escape\.xacro: .*")
    assert not marker.exists()


def test_stock_xacro_runs_the_eval_payload(tmp_path: Path) -> None:
    """Why the sandbox: stock $(eval) has every builtin (the text '__' is all it refuses)."""
    marker = tmp_path / "MARKER"
    path = write(tmp_path / "stock.xacro", robot(f"""
  <xacro:property name="payload" value="open('{marker}', 'w').close()"/>
  <link name="$(eval ${{payload}})"/>"""))
    expand_stock(path)
    if not marker.exists():
        pytest.skip("this xacro no longer runs $(eval) with builtins")
    marker.unlink()
    refused(path, r"name 'open' is not defined")
    assert not marker.exists()


@pytest.mark.parametrize("expression, reason", [
    ("${(lambda: ().__class__)()}", r"attribute '__class__' \(names starting with '_' are refused\)"),
    ("${python.type(1)}", r"python\.type\(\) is not available"),
    ("${int.mro()}", r"attribute '\.mro' is refused"),
    ("${fmt.format(1)}", r"format field '\{0\.__class__\}'"),
    ("$(eval __import__)", r"\$\(eval __import__\) refused: name '__import__'"),
    ("$(eval open)", r"name 'open' is not defined"),
    ("${10**10**9}", r"'\*\*' would make an integer of more than 4,096 bits"),
    ("${'x' * 10**9}", r"'\*' would make 1,000,000,000 characters"),
    ("${1 &lt;&lt; 10**6}", r"'<<' would make an integer"),
    ("${[0] * 10**7}", r"'\*' would make"),
    ("${'x'.ljust(10**9)}", r"'\.ljust' would make"),
    ("${'%1000000000d' % 1}", r"'%' formatting with widths past"),
    ("$(eval f'{1:>1000000000}')", r"f-string field with a width past"),
    ("${len([x for x in python.range(10**8)])}", r"too much work"),
    ("${math.factorial(10**7)}", r"math\.factorial\(\) of more than 1000"),
])
def test_refusals_name_the_file_and_expression(tmp_path: Path, expression: str, reason: str) -> None:
    path = write(tmp_path / "refused.xacro", robot(f"""
  <xacro:property name="fmt" value="{{0.__class__}}"/>
  <link name="{expression}"/>"""))
    start = time.process_time()
    message = refused(path, reason)
    assert time.process_time() - start < 30  # a hang guard in CPU seconds (~1 s); speed lives in benchmarks/
    assert "refused" in message


def test_a_refused_expression_inside_a_macro_names_the_file(tmp_path: Path) -> None:
    write(tmp_path / "macros.xacro", robot("""
  <xacro:macro name="m" params="v"><link name="${v.gi_frame}"/></xacro:macro>"""))
    path = write(tmp_path / "top.xacro", robot("""
  <xacro:include filename="macros.xacro"/>
  <xacro:m v="${(x for x in [1])}"/>"""))
    message = refused(path, r"attribute '\.gi_frame' is refused")
    assert message.startswith(display_path(path))


def test_property_doubling_is_refused(tmp_path: Path) -> None:
    doubling = "".join(f'<xacro:property name="a{i + 1}" value="${{a{i} + a{i}}}"/>' for i in range(40))
    path = write(tmp_path / "doubling.xacro", robot(f'<xacro:property name="a0" value="xxxxxxxxxx"/>{doubling}'
                                                    '<link name="${a40}"/>'))
    refused(path, r"'\+' would make 1,310,720 characters")


def test_expression_output_is_bounded_over_the_expansion(tmp_path: Path) -> None:
    links = "".join(f'<link name="${{big}}" i="{i}"/>' for i in range(30))
    path = write(tmp_path / "output.xacro", robot(f'<xacro:property name="big" value="${{\'x\' * 900000}}"/>{links}'))
    refused(path, r"expressions made more than 10,000,000 characters",
            limits=SandboxLimits(max_expression_output=10_000_000))


# ---- files: only the description's own places ------------------------------------------------


@pytest.fixture
def workspace(tmp_path: Path) -> Path:
    """A colcon workspace: src/robot_description (the input's package) and src/tools (a sibling)."""
    ws = tmp_path / "ws"
    pkg = ws / "src" / "robot_description"
    write(pkg / "package.xml", "<package><name>robot_description</name></package>")
    write(pkg / "config" / "limits.yaml", "limit: 1.5\n")
    write(ws / "src" / "tools" / "package.xml", "<package><name>tools</name></package>")
    write(ws / "src" / "tools" / "common.xacro", robot('<link name="from_tools"/>'))
    write(tmp_path / "outside" / "secret.xacro", robot('<link name="secret"/>'))
    write(tmp_path / "outside" / "secret.yaml", "secret: do-not-leak-7f3c9e\n")
    return ws


def test_reads_inside_the_workspace(workspace: Path) -> None:
    pkg = workspace / "src" / "robot_description"
    path = write(pkg / "urdf" / "robot.urdf.xacro", robot("""
  <xacro:include filename="$(find tools)/common.xacro"/>
  <xacro:include filename="../../tools/common.xacro"/>
  <link name="base" limit="${xacro.load_yaml('$(find robot_description)/config/limits.yaml').limit}"/>"""))
    urdf = expand(path)
    assert urdf.count('name="from_tools"') == 2 and 'limit="1.5"' in urdf


@pytest.mark.parametrize("element", [
    '<xacro:include filename="/etc/passwd"/>',
    '<xacro:include filename="../../../../../../../../../../etc/passwd"/>',
    '<xacro:include filename="/etc/passwd" optional="true"/>',
    '<xacro:include filename="/etc/pass*"/>',
    '<xacro:include filename="$(find robot_description)/../../../outside/secret.xacro"/>',
    '<link name="${load_yaml(\'/etc/passwd\')}"/>',
    '<link name="${xacro.load_yaml(\'/etc/passwd\')}"/>',
    '<link name="${xacro.load_yaml(\'../../../../../../../../../etc/passwd\')}"/>',
    '<link name="${xacro.load_yaml(\'$(find robot_description)/../../../outside/secret.yaml\')}"/>',
])
def test_reads_outside_are_refused(workspace: Path, element: str) -> None:
    path = write(workspace / "src" / "robot_description" / "urdf" / "robot.urdf.xacro", robot(element))
    message = refused(path, r"robot\.urdf\.xacro: (<xacro:include filename=|xacro\.load_yaml\().* refused: .* is "
                            r"outside the folders a description may read")
    assert "do-not-leak-7f3c9e" not in message and 'name="secret"' not in message


def test_a_link_out_of_an_allowed_folder_is_refused(tmp_path: Path) -> None:
    folder = tmp_path / "robot"
    (folder / "passwd.xacro").parent.mkdir(parents=True)
    (folder / "passwd.xacro").symlink_to(PASSWD)
    (folder / "passwd.yaml").symlink_to(PASSWD)
    path = write(folder / "robot.xacro", robot('<xacro:include filename="passwd.xacro"/>'))
    message = refused(path, r'<xacro:include filename="passwd\.xacro"> refused: \S*/passwd\.xacro \(a link to /etc/passwd\)')
    assert "outside the folders" in message
    write(path, robot("<link name=\"${xacro.load_yaml('passwd.yaml')}\"/>"))
    refused(path, r"xacro\.load_yaml\('passwd\.yaml'\) refused: .*passwd\.yaml \(a link to /etc/passwd\)")


def test_colcon_symlink_install_is_readable_but_its_links_out_are_not(tmp_path: Path) -> None:
    """install/<pkg>/share/<pkg> holds links into src/<pkg>; $(find) resolves the installed copy."""
    src = tmp_path / "ws" / "src" / "arm_description"
    write(src / "package.xml", "<package><name>arm_description</name></package>")
    write(src / "urdf" / "arm.xacro", robot("""
  <xacro:include filename="parts.xacro"/>
  <link name="arm" reach="${xacro.load_yaml('$(find arm_description)/config/arm.yaml').reach}"/>"""))
    write(src / "urdf" / "parts.xacro", robot('<link name="part"/>'))
    write(src / "config" / "arm.yaml", "reach: 0.85\n")
    prefix = tmp_path / "ws" / "install" / "arm_description"
    share = prefix / "share" / "arm_description"
    for relative in ("package.xml", "urdf/arm.xacro", "urdf/parts.xacro", "config/arm.yaml"):
        (share / relative).parent.mkdir(parents=True, exist_ok=True)
        (share / relative).symlink_to(src / relative)
    (share / "config" / "evil.yaml").symlink_to(PASSWD)
    elsewhere = tmp_path / "bringup"
    environ = {"AMENT_PREFIX_PATH": str(prefix)}
    path = write(elsewhere / "cell.xacro", robot('<xacro:include filename="$(find arm_description)/urdf/arm.xacro"/>'))
    urdf = expand(path, environ=environ)
    assert 'name="part"' in urdf and 'reach="0.85"' in urdf
    write(path, robot("<link name=\"${xacro.load_yaml('$(find arm_description)/config/evil.yaml')}\"/>"))
    with pytest.raises(DescriptionError, match=r"cell\.xacro: xacro\.load_yaml\(.*evil\.yaml'\) refused: .*evil\.yaml "
                                               r"\(a link to /etc/passwd\) is outside") as caught:
        expand(path, environ=environ)
    assert "root:" not in str(caught.value)


def test_package_paths_and_allow_paths_are_readable(tmp_path: Path) -> None:
    shared = tmp_path / "shared"
    write(shared / "common.xacro", robot('<link name="shared"/>'))
    extra = write(tmp_path / "extra" / "one.yaml", "value: 7\n")
    path = write(tmp_path / "robot" / "r.xacro", robot(f"""
  <xacro:include filename="{shared / 'common.xacro'}"/>
  <link name="x" v="${{xacro.load_yaml('{extra}').value}}"/>"""))
    refused(path, r"common\.xacro\"> refused")
    urdf = expand(path, package_paths=[shared], allow_paths=[extra])
    assert 'name="shared"' in urdf and 'v="7"' in urdf


def test_a_home_folder_is_not_a_workspace(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """An input directly in the home folder may read itself, not its neighbours (~/.ssh/…)."""
    home = tmp_path / "home"
    monkeypatch.setenv("HOME", str(home))
    write(home / ".ssh" / "id_rsa.xacro", robot('<link name="key"/>'))
    path = write(home / "robot.xacro", robot('<xacro:include filename=".ssh/id_rsa.xacro"/>'))
    refused(path, r"refused: \S*/\.ssh/id_rsa\.xacro is outside")


# ---- expansion size ------------------------------------------------------------------------


def _doubling_macros(levels: int, body: str) -> str:
    macros = "".join(f'<xacro:macro name="m{i + 1}">{body.format(i)}</xacro:macro>' for i in range(levels))
    return robot(f'<xacro:macro name="m0"><e/></xacro:macro>{macros}<xacro:m{levels}/>')


def test_exponential_macros_side_by_side_are_refused(tmp_path: Path) -> None:
    path = write(tmp_path / "flat.xacro", _doubling_macros(30, "<xacro:m{0}/><xacro:m{0}/>"))
    start = time.process_time()
    refused(path, r"flat\.xacro: <xacro:m\d+> expands past 10,000,000 steps of sibling insertion")
    assert time.process_time() - start < 30  # a hang guard in CPU seconds


def test_exponential_macros_nested_are_refused(tmp_path: Path) -> None:
    path = write(tmp_path / "nested.xacro", _doubling_macros(30, "<g><xacro:m{0}/></g><g><xacro:m{0}/></g>"))
    refused(path, r"nested\.xacro: macro 'm\d+' expands past 20,000 element copies",
            limits=SandboxLimits(max_element_copies=20_000))


def test_exponential_blocks_are_refused(tmp_path: Path) -> None:
    path = write(tmp_path / "blocks.xacro", robot("""
  <xacro:macro name="d" params="n **b">
    <xacro:if value="${n}">
      <xacro:d n="${n - 1}"><c><g><xacro:insert_block name="b"/></g><g><xacro:insert_block name="b"/></g></c></xacro:d>
    </xacro:if>
    <xacro:unless value="${n}"><out><xacro:insert_block name="b"/></out></xacro:unless>
  </xacro:macro>
  <xacro:d n="40"><c><e/></c></xacro:d>"""))
    refused(path, r"blocks\.xacro: (<xacro:insert_block name=\"b\">|macro 'd') expands past 20,000 element copies",
            limits=SandboxLimits(max_element_copies=20_000))


def test_deep_recursion_still_reads_as_recursion(tmp_path: Path) -> None:
    path = write(tmp_path / "recursive.xacro", robot('<xacro:macro name="m"><g><xacro:m/></g></xacro:macro><xacro:m/>'))
    refused(path, r"recursive\.xacro: xacro recursion too deep")


def test_deep_xml_is_nested_too_deeply_not_recursion(tmp_path: Path) -> None:
    path = write(tmp_path / "deep.xacro", f"<robot {XMLNS} name='r'>" + "<a>" * 100_000 + "</a>" * 100_000 + "</robot>")
    refused(path, r"deep\.xacro: XML nested too deeply \(more than 200 levels\)")
    included = write(tmp_path / "includes_deep.xacro", robot('<xacro:include filename="deep.xacro"/>'))
    with pytest.raises(DescriptionError, match=r"deep\.xacro: XML nested too deeply"):
        expand(included)


def test_nesting_below_the_bound_expands(tmp_path: Path) -> None:
    path = write(tmp_path / "ok.xacro", robot("<a>" * 190 + '<link name="${1 + 1}"/>' + "</a>" * 190))
    assert expand(path) == expand_stock(path)


def test_a_large_file_is_refused(tmp_path: Path) -> None:
    write(tmp_path / "big.xacro", robot("<!--" + "x" * 5000 + "-->"))
    path = write(tmp_path / "top.xacro", robot('<xacro:include filename="big.xacro"/>'))
    refused(path, r"top\.xacro: .*big\.xacro: larger than the 1,000 bytes", limits=SandboxLimits(max_file_bytes=1000))


# ---- malformed xacro elements --------------------------------------------------------------


@pytest.mark.parametrize("element, tag, attribute", [
    ("<xacro:include/>", "xacro:include", "filename"),
    ("<xacro:property/>", "xacro:property", "name"),
    ("<xacro:arg/>", "xacro:arg", "name"),
    ('<xacro:arg name="a"/>', "xacro:arg", "default"),
    ("<xacro:if/>", "xacro:if", "value"),
    ("<xacro:unless/>", "xacro:unless", "value"),
    ("<xacro:macro/>", "xacro:macro", "name"),
    ("<xacro:element/>", "xacro:element", "xacro:name"),
    ("<xacro:attribute/>", "xacro:attribute", "name"),
    ('<xacro:attribute name="a"/>', "xacro:attribute", "value"),
    ("<xacro:insert_block/>", "xacro:insert_block", "name"),
    ("<xacro:call/>", "xacro:call", "macro"),
])
def test_missing_attributes_give_one_line(tmp_path: Path, element: str, tag: str, attribute: str) -> None:
    path = write(tmp_path / "malformed.xacro", robot(f"<link name='a'>{element}</link>"))
    message = refused(path, "has no")
    assert message == f"{display_path(path)}: <{tag}> has no '{attribute}' attribute"


def test_missing_attribute_in_an_included_file_names_that_file(tmp_path: Path) -> None:
    inner = write(tmp_path / "inner.xacro", robot("<xacro:property/>"))
    path = write(tmp_path / "outer.xacro", robot('<xacro:include filename="inner.xacro"/>'))
    with pytest.raises(DescriptionError) as caught:
        expand(path)
    assert str(caught.value) == f"{display_path(inner)}: <xacro:property> has no 'name' attribute"


def test_describe_xacro_failure_leaves_other_errors_alone() -> None:
    assert describe_xacro_failure(RuntimeError("something else"), filename="x.xacro") is None
    assert describe_xacro_failure(RecursionError("maximum recursion depth exceeded"), filename="x.xacro") is None
    wrapped = ValueError("outer")
    wrapped.__cause__ = SandboxRefusal("x.xacro: refused")
    assert describe_xacro_failure(wrapped, filename="x.xacro") == "x.xacro: refused"


# ---- encodings ------------------------------------------------------------------------------

TEXT = ('<?xml version="1.0" encoding="ENCODING"?>\n<robot ' + XMLNS +
        ' name="röbot">\n  <link name="${\'é\' + \'ß\'}"/>\n</robot>\n')


@pytest.mark.parametrize("declared, codec", [("UTF-16", "utf-16"), ("UTF-16", "utf-16-be"), ("ISO-8859-1", "latin-1"),
                                             ("windows-1252", "cp1252"), ("UTF-8", "utf-8-sig")])
def test_declared_encodings_load(tmp_path: Path, declared: str, codec: str) -> None:
    (tmp_path / "encoded.xacro").write_bytes(TEXT.replace("ENCODING", declared).encode(codec))
    urdf = expand(tmp_path / "encoded.xacro")
    assert 'name="röbot"' in urdf and 'name="éß"' in urdf
    write(tmp_path / "top.xacro", robot('<xacro:include filename="encoded.xacro"/>'))
    assert 'name="éß"' in expand(tmp_path / "top.xacro")


def test_stock_xacro_reads_utf16_as_utf8(tmp_path: Path) -> None:
    (tmp_path / "utf16.xacro").write_bytes(TEXT.replace("ENCODING", "UTF-16").encode("utf-16"))
    with pytest.raises(UnicodeDecodeError):
        expand_stock(tmp_path / "utf16.xacro")


@pytest.mark.parametrize("codec", ["utf-8", "utf-16", "utf-16-le", "latin-1"])
def test_decode_xml_keeps_the_text(codec: str) -> None:
    text = TEXT.replace("ENCODING", {"utf-8": "UTF-8", "latin-1": "ISO-8859-1"}.get(codec, "UTF-16"))
    assert decode_xml(text.encode(codec), where="x.urdf") == text
    root = parse_xml(text.encode(codec)).documentElement
    assert root is not None and root.getAttribute("name") == "röbot"


def test_decode_xml_can_declare_utf8() -> None:
    text = TEXT.replace("ENCODING", "UTF-16")
    decoded = decode_xml(text.encode("utf-16"), where="x.urdf", declare_utf8=True)
    assert decoded == text.replace('encoding="UTF-16"', 'encoding="UTF-8"')
    assert parse_xml(decoded.encode("utf-8")).documentElement is not None
    latin = TEXT.replace("ENCODING", "ISO-8859-1").replace('"', "'", 4)
    assert "encoding='UTF-8'" in decode_xml(latin.encode("latin-1"), where="x.urdf", declare_utf8=True)


def test_decode_xml_names_the_file_of_malformed_bytes() -> None:
    with pytest.raises(DescriptionError, match=r"^x\.urdf:1:\d+: malformed XML: "):
        decode_xml("<a><b></a>".encode("utf-16"), where="x.urdf")


# ---- the sandbox leaves xacro as it found it -------------------------------------------------


def test_xacro_is_restored_after_the_sandbox(tmp_path: Path) -> None:
    import xacro
    import xacro.substitution_args as subst

    def snapshot() -> Iterator[object]:
        yield from (xacro.safe_eval, xacro.parse, xacro.process_include, xacro.handle_macro_call, xacro.replace_node,
                    subst._eval, dict.get(xacro._global_symbols, "load_yaml"),
                    dict.get(dict.__getitem__(xacro._global_symbols, "python"), "type"),
                    dict.get(dict.__getitem__(xacro._global_symbols, "xacro"), "load_yaml"),
                    hasattr(xacro, "open"))

    before = list(snapshot())
    path = write(tmp_path / "bad.xacro", robot("<link name='${().__class__}'/>"))
    with pytest.raises(DescriptionError):
        expand(path)
    assert list(snapshot()) == before


def test_symbols_mutated_by_an_expression_are_restored(tmp_path: Path) -> None:
    import xacro

    python = dict.__getitem__(xacro._global_symbols, "python")
    write(tmp_path / "lib.xacro", robot('<xacro:property name="x" value="1"/>'))
    path = write(tmp_path / "mutate.xacro", robot("""
  <xacro:include filename="lib.xacro" ns="lib"/>
  <link name="${[python.update(dict(sorted=python.abs)), lib.parent.update(dict(radians=python.abs)), 1][2]}"/>
  <link name="${python.sorted(-2)}" r="${radians(-3)}"/>"""))
    urdf = expand(path)
    assert 'name="2"' in urdf and 'r="3"' in urdf  # within the expansion, as stock xacro would
    assert dict.__getitem__(python, "sorted") is sorted
    assert 'name="[1, 2, 3]"' in expand(write(tmp_path / "after.xacro", robot('<link name="${python.sorted([3, 1, 2])}"/>')))


def test_yaml_bounds_apply_to_load_yaml(tmp_path: Path) -> None:
    levels = ['a0: &a0 ["lol"]'] + [f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * 10) + "]" for i in range(1, 10)]
    bomb = write(tmp_path / "bomb.yaml", "\n".join(levels) + "\n")
    path = write(tmp_path / "robot.xacro", robot("<link name=\"${xacro.load_yaml('bomb.yaml')}\"/>"))
    message = refused(path, r"robot\.xacro: \S*bomb\.yaml: YAML expands to more than 2,000,000 nodes")
    assert message == f"{display_path(path)}: {display_path(bomb)}: YAML expands to more than 2,000,000 nodes " \
                      "(aliases counted in full)"
    write(bomb, "a: [1, 2\n")
    refused(path, r"robot\.xacro: \S*bomb\.yaml:2: not valid YAML: expected ',' or ']'")


def test_an_unknown_package_names_the_file_that_asked(tmp_path: Path) -> None:
    path = write(tmp_path / "robot.xacro", robot('<xacro:include filename="$(find nowhere)/x.xacro"/>'))
    refused(path, r"robot\.xacro: package 'nowhere' not found")


def test_macro_calls_can_be_counted_from_the_callers_own_patch(tmp_path: Path) -> None:
    """wrap_macro_calls=False: the caller's patch of handle_macro_call (the legacy-dialect one)
    calls count_macro_call itself, and the sandbox leaves handle_macro_call alone."""
    import xacro

    path = write(tmp_path / "nested.xacro", _doubling_macros(30, "<g><xacro:m{0}/></g><g><xacro:m{0}/></g>"))
    finder = PackageFinder([], near=path, environ={})
    stock = xacro.handle_macro_call
    with _LOCK, xacro_sandbox(path, finder=finder, limits=SandboxLimits(max_element_copies=5000),
                              wrap_macro_calls=False) as sandbox:
        assert xacro.handle_macro_call is stock

        def merged(node: object, macros: object, symbols: object) -> bool:
            sandbox.count_macro_call(node, macros, symbols)
            return bool(stock(node, macros, symbols))

        xacro.handle_macro_call = merged
        try:
            with contextlib.redirect_stderr(io.StringIO()), pytest.raises(
                    SandboxRefusal, match=r"nested\.xacro: macro 'm\d+' expands past 5,000 element copies"):
                xacro.init_stacks(str(path))
                xacro.process_doc(xacro.parse(None, str(path)))
        finally:
            xacro.handle_macro_call = stock
