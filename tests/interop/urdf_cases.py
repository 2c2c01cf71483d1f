"""Generated URDF edge cases, each compared with real check_urdf (urdfdom 3.0.1): accepted or refused by both, and
when accepted the same name, root and tree. :data:`DIFFERENCES` are the cases where tfrec refuses on purpose what
urdfdom loads (docs/ros-parity.md says why)."""

from __future__ import annotations

TWO = '<link name="a"/><link name="b"/>'
LIMIT = '<limit lower="-1" upper="1" effort="1" velocity="1"/>'
JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")


def robot(body: str, *, attrs: str = ' name="r"', declaration: str = "") -> str:
    return f"{declaration}<robot{attrs}>{body}</robot>\n"


def joint(jtype: str, inside: str = "", *, name: str = "j", parent: str = "a", child: str = "b") -> str:
    return f'<joint name="{name}" type="{jtype}"><parent link="{parent}"/><child link="{child}"/>{inside}</joint>'


def _versions() -> dict[str, str]:
    versions = ["1.0", "1", "1.1", "1.2", "2.0", "0.9", "abc", "1.0.0", "1..0", "1.", ".0", "", " 1.0", "1.0 ",
                "+1.0", "-1.0", "1.-0", "01.00", "a.b", "1.0x", "0x1.0", "1.0e0", "4294967297.0", "1. 0"]
    return {f"version[{v}]": robot(TWO + joint("fixed"), attrs=f' name="r" version="{v}"') for v in versions}


def _limits() -> dict[str, str]:
    limits = {
        "none": "", "full": LIMIT, "no-effort": '<limit lower="-1" upper="1" velocity="1"/>',
        "no-velocity": '<limit lower="-1" upper="1" effort="1"/>', "empty": "<limit/>",
        "bad-number": '<limit lower="x" upper="1" effort="1" velocity="1"/>',
        "infinite": '<limit lower="-inf" upper="inf" effort="1" velocity="1"/>',
        "lower-above-upper": '<limit lower="1" upper="-1" effort="1" velocity="1"/>',
        "only-effort-velocity": '<limit effort="1" velocity="1"/>',
        "negative-effort": '<limit lower="-1" upper="1" effort="-1" velocity="1"/>',
    }
    return {f"limit[{jtype}-{name}]": robot(TWO + joint(jtype, text)) for jtype in JOINT_TYPES
            for name, text in limits.items()}


def _axes() -> dict[str, str]:
    axes = {"zero": "0 0 0", "two": "1 0", "nan": "nan 0 1", "huge": "1e200 1e200 1e200", "tiny": "1e-200 0 0",
            "unnormalized": "0 0 5", "negative": "0 -1 0", "text": "x y z"}
    return {f"axis[{jtype}-{name}]": robot(TWO + joint(jtype, f'<axis xyz="{xyz}"/>' + (LIMIT if jtype in (
        "revolute", "prismatic") else ""))) for jtype in ("revolute", "continuous", "prismatic", "fixed", "planar")
            for name, xyz in axes.items()}


def _origins() -> dict[str, str]:
    origins = {"two": 'xyz="1 2"', "nan": 'xyz="nan 0 1"', "inf": 'xyz="inf 0 1"', "rpy-text": 'rpy="0 x 0"',
               "empty": "", "commas": 'xyz="1,2,3"', "extra-spaces": 'xyz="  1   2  3 "', "four": 'rpy="0 0 0 0"'}
    return {f"origin[{name}]": robot(TWO + joint("fixed", f"<origin {attrs}/>")) for name, attrs in origins.items()}


def _visuals() -> dict[str, str]:
    visuals = {
        "box-no-size": "<geometry><box/></geometry>", "box-two": '<geometry><box size="1 1"/></geometry>',
        "mesh-no-filename": "<geometry><mesh/></geometry>",
        "mesh-bad-scale": '<geometry><mesh filename="m.stl" scale="1 1"/></geometry>',
        "cylinder-no-radius": '<geometry><cylinder length="1"/></geometry>',
        "cylinder-no-length": '<geometry><cylinder radius="1"/></geometry>',
        "sphere-no-radius": "<geometry><sphere/></geometry>", "sphere-negative": '<geometry><sphere radius="-1"/></geometry>',
        "geometry-empty": "<geometry/>", "geometry-unknown": '<geometry><capsule radius="1" length="1"/></geometry>',
        "no-geometry": "", "bad-origin": '<origin xyz="1 2"/><geometry><sphere radius="1"/></geometry>',
        "material-no-name": '<geometry><sphere radius="1"/></geometry><material><color rgba="1 0 0 1"/></material>',
        "material-bad-rgba": '<geometry><sphere radius="1"/></geometry><material name="m"><color rgba="1 0"/></material>',
        "material-undefined": '<geometry><sphere radius="1"/></geometry><material name="nowhere"/>',
    }
    out = {}
    for name, inside in visuals.items():
        out[f"visual[{name}]"] = robot(f'<link name="a"><visual>{inside}</visual></link><link name="b"/>' + joint("fixed"))
        out[f"collision[{name}]"] = robot(f'<link name="a"><collision>{inside}</collision></link><link name="b"/>'
                                          + joint("fixed"))
    return out


def _links() -> dict[str, str]:
    inertials = {"mass-no-value": "<mass/>", "mass-text": '<mass value="x"/>',
                 "inertia-text": '<mass value="1"/><inertia ixx="x" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/>',
                 "inertia-missing": '<mass value="1"/><inertia ixx="1"/>', "origin-bad": '<origin xyz="1"/><mass value="1"/>'}
    out = {f"inertial[{name}]": robot(f'<link name="a"><inertial>{inside}</inertial></link><link name="b"/>'
                                      + joint("fixed")) for name, inside in inertials.items()}
    materials = {
        "bad-rgba": '<material name="m"><color rgba="1 0"/></material>',
        "no-name": '<material><color rgba="1 0 0 1"/></material>',
        "twice-equal": '<material name="m"><color rgba="1 0 0 1"/></material>' * 2,
        "twice-different": '<material name="m"><color rgba="1 0 0 1"/></material><material name="m"><color rgba="0 1 0 1"/>'
                           "</material>",
        "texture-only": '<material name="t"><texture filename="t.png"/></material>',
    }
    out.update({f"material[{name}]": robot(text + TWO + joint("fixed")) for name, text in materials.items()})
    return out


def _joint_parts() -> dict[str, str]:
    parts = {
        "safety-no-k-velocity": '<safety_controller soft_lower_limit="-0.5"/>',
        "safety-full": '<safety_controller soft_lower_limit="-0.5" soft_upper_limit="0.5" k_position="1" k_velocity="1"/>',
        "safety-bad-soft": '<safety_controller soft_lower_limit="x" k_velocity="1"/>',
        "safety-bad-k-position": '<safety_controller k_position="x" k_velocity="1"/>',
        "dynamics-bad": '<dynamics damping="x"/>', "dynamics-ok": '<dynamics damping="0.1" friction="0.2"/>',
        "calibration-bad": '<calibration rising="x"/>', "calibration-ok": '<calibration rising="0.1"/>',
        "mimic-no-joint": "<mimic/>", "mimic-unknown": '<mimic joint="nobody"/>',
        "mimic-bad-multiplier": '<mimic joint="j0" multiplier="x"/>',
    }
    base = '<link name="a"/><link name="b"/><link name="c"/>' + joint("revolute", LIMIT, name="j0", child="c")
    return {f"joint[{name}]": robot(base + joint("revolute", LIMIT + inside)) for name, inside in parts.items()}


def _trees() -> dict[str, str]:
    three = '<link name="a"/><link name="b"/><link name="c"/>'
    return {
        "tree[two-roots]": robot(TWO),
        "tree[cycle]": robot(three + joint("fixed", child="b") + joint("fixed", name="k", parent="b", child="c")
                             + joint("fixed", name="l", parent="c", child="b")),
        "tree[loop-to-root]": robot(TWO + joint("fixed") + joint("fixed", name="k", parent="b", child="a")),
        "tree[self-joint]": robot('<link name="a"/>' + joint("fixed", child="a")),
        "tree[unknown-parent]": robot(TWO + joint("fixed", parent="x")),
        "tree[unknown-child]": robot(TWO + joint("fixed", child="x")),
        "tree[duplicate-link]": robot(TWO + '<link name="a"/>' + joint("fixed")),
        "tree[duplicate-joint]": robot(three + joint("fixed") + joint("fixed", child="c")),
        "tree[child-of-two]": robot(three + joint("fixed") + joint("fixed", name="k", parent="c", child="b")),
        "tree[no-links]": robot(""),
        "tree[one-link]": robot('<link name="a"/>'),
        "tree[branching]": robot(three + '<link name="d"/>' + joint("fixed") + joint("fixed", name="k", child="c")
                                 + joint("fixed", name="l", parent="b", child="d")),
        "tree[joint-before-links]": robot(joint("fixed") + TWO),
        "tree[link-no-name]": robot("<link/>"),
        "tree[joint-no-name]": robot(TWO + '<joint type="fixed"><parent link="a"/><child link="b"/></joint>'),
        "tree[joint-no-type]": robot(TWO + '<joint name="j"><parent link="a"/><child link="b"/></joint>'),
        "tree[joint-unknown-type]": robot(TWO + joint("hinge")),
        "tree[joint-no-parent]": robot(TWO + '<joint name="j" type="fixed"><child link="b"/></joint>'),
        "tree[robot-no-name]": robot('<link name="a"/>', attrs=""),
        "tree[robot-empty-name]": robot('<link name="a"/>', attrs=' name=""'),
        "tree[mimic-cycle]": robot(three + joint("continuous", '<mimic joint="k"/>', child="b")
                                   + joint("continuous", '<mimic joint="j"/>', name="k", child="c")),
        "tree[mimic-chain]": robot(three + '<link name="d"/>' + joint("continuous", child="b")
                                   + joint("continuous", '<mimic joint="j" multiplier="2"/>', name="k", child="c")
                                   + joint("continuous", '<mimic joint="k" offset="1"/>', name="l", child="d")),
        "tree[unknown-elements]": robot(TWO + joint("fixed", '<orgin xyz="1 0 0"/>') + '<gazebo><plugin/></gazebo>'
                                        '<transmission name="t"/><wheel/>'),
        "tree[root-not-robot]": '<model name="r"><link name="a"/></model>\n',
    }


def _declarations() -> dict[str, str]:
    declarations = {"misspelled": '<?xml verison="1.0"?>', "empty": "<?xml?>", "unquoted": "<?xml version=1.0?>",
                    "upper-case": '<?XML version="1.0"?>', "standalone-maybe": '<?xml version="1.0" standalone="maybe"?>',
                    "bogus-encoding": '<?xml version="1.0" encoding="bogus"?>', "blank-line-first": '\n<?xml version="1.0"?>',
                    "version-2": '<?xml version="2.0"?>', "valid": '<?xml version="1.0" encoding="UTF-8"?>'}
    return {f"declaration[{name}]": robot('<link name="a"/>', declaration=text + "\n")
            for name, text in declarations.items()}


CASES: dict[str, str] = {**_versions(), **_limits(), **_axes(), **_origins(), **_visuals(), **_links(),
                         **_joint_parts(), **_trees(), **_declarations()}
"""Case id → URDF text."""

DIFFERENCES: dict[str, str] = {
    **{f"axis[{jtype}-zero]": "a zero axis defines no motion (robot_state_publisher publishes NaN)"
       for jtype in ("revolute", "continuous", "prismatic", "planar")},
    "tree[mimic-cycle]": "mimic joints in a cycle define no position",
    "tree[cycle]": "a link that is the child of two joints: urdfdom keeps the last as its parent and prints the tree "
                   "forever",
    "version[1.1]": "URDF 1.1: urdfdom 3.0.1 refuses it, newer urdfdom reads it; tfrec reads it with a warning",
    "tree[link-no-name]": "a link without a name is no TF frame",
}
"""Cases urdfdom 3.0.1 loads and tfrec refuses on purpose, and why."""
