"""The inputs of xacro's own test suite, to expand with tfrec and with PyPI xacro and compare.

Transcribed from ros/xacro's ``test/test_xacro.py`` (melodic era, the version that still tests both
the legacy and the in-order processing; BSD-3-Clause, Copyright (c) 2015 Open Source Robotics
Foundation, Inc., (c) 2013 Willow Garage, Inc.): each case's input document and command-line
arguments, named after its test. Its expected results are not copied: the oracle is PyPI xacro
itself (tests/description/xacro_oracle.py), whose results for the same inputs tfrec must match. The
support files the suite reads (``include1.xml``, ``settings.yaml`` …) are rebuilt in :data:`FILES`
with the content its tests expect; the PR2 snapshot (``robots/pr2``) is not.
"""

from __future__ import annotations

from dataclasses import dataclass, field

NS = 'xmlns:xacro="http://www.ros.org/wiki/xacro"'


@dataclass(frozen=True)
class Case:
    """One input of xacro's test suite.

    Attributes:
        src: the document.
        args: its ``name:=value`` arguments.
        legacy: the input with the prefixes xacro <= 1.13 let one omit written out, for a robot
            description (``<robot>`` root) that uses the legacy dialect: tfrec expands ``src`` as PyPI
            xacro expands ``legacy``. (In a document of another kind, legacy forms are PyPI xacro's to
            leave alone.)
    """

    src: str
    args: dict[str, str] = field(default_factory=dict)
    legacy: str | None = None


def _a(body: str, tag: str = "a") -> str:
    return f"<{tag} {NS}>{body}</{tag}>"


CASES: dict[str, Case] = {
    "invalid_property_name": Case(_a('<xacro:property name="invalid.name"/>')),
    "dynamic_macro_names-foo": Case(_a('<xacro:macro name="foo"><a>foo</a></xacro:macro>'
                                      '<xacro:macro name="bar"><b>bar</b></xacro:macro>'
                                      '<xacro:property name="var" value="foo"/><xacro:call macro="${var}"/>')),
    "dynamic_macro_names-bar": Case(_a('<xacro:macro name="foo"><a>foo</a></xacro:macro>'
                                      '<xacro:macro name="bar"><b>bar</b></xacro:macro>'
                                      '<xacro:property name="var" value="bar"/><xacro:call macro="${var}"/>')),
    "dynamic_macro_name_clash": Case(_a('<xacro:macro name="foo"><a name="foo"/></xacro:macro>'
                                       '<xacro:macro name="call"><a name="bar"/></xacro:macro><xacro:call/>')),
    "dynamic_macro_undefined": Case(_a('<xacro:call macro="foo"/>')),
    "macro_undefined": Case(_a("<xacro:undefined><foo/><bar/></xacro:undefined>")),
    "xacro_element": Case(_a('<xacro:macro name="foo" params="name"><xacro:element xacro:name="${name}"/>'
                             '</xacro:macro><xacro:foo name="A"/><xacro:foo name="B"/>')),
    "xacro_attribute": Case(_a('<xacro:macro name="foo" params="name value"><tag><xacro:attribute name="${name}" '
                               'value="${value}"/></tag></xacro:macro><xacro:foo name="A" value="foo"/>'
                               '<xacro:foo name="B" value="bar"/>')),
    "inorder_processing": Case(_a('<xacro:property name="foo" value="1.0"/>'
                                  '<xacro:macro name="m" params="foo"><a foo="${foo}"/></xacro:macro>'
                                  '<xacro:m foo="1 ${foo}"/><!-- now redefining the property and macro -->'
                                  '<xacro:property name="foo" value="2.0"/>'
                                  '<xacro:macro name="m" params="foo"><b bar="${foo}"/></xacro:macro>'
                                  '<xacro:m foo="2 ${foo}"/>', "xml")),
    "should_replace_before_macroexpand": Case(_a(
        '<xacro:macro name="inner" params="*the_block"><in_the_inner><xacro:insert_block name="the_block" />'
        '</in_the_inner></xacro:macro><xacro:macro name="outer" params="*the_block"><in_the_outer><xacro:inner>'
        '<xacro:insert_block name="the_block" /></xacro:inner></in_the_outer></xacro:macro>'
        "<xacro:outer><woot /></xacro:outer>")),
    "evaluate_macro_params_before_body": Case(_a('<xacro:macro name="foo" params="lst">${lst[-1]}</xacro:macro>'
                                                 '<xacro:foo lst="${[1,2,3]}"/>')),
    "macro_params_escaped_string": Case(_a('<xacro:macro name="foo" params="a=\'1 -2\' c=3"><bar a="${a}" '
                                           'c="${c}"/></xacro:macro><xacro:foo/>')),
    "property_replacement": Case(_a('<xacro:property name="foo" value="42" /><the_foo result="${foo}" />')),
    "property_scope_parent": Case(_a('<xacro:macro name="foo" params="factor"><xacro:property name="foo" '
                                     'value="${21*factor}" scope="parent"/></xacro:macro><xacro:foo factor="2"/>'
                                     '<a foo="${foo}"/>')),
    "property_scope_global": Case(_a('<xacro:macro name="foo" params="factor"><xacro:macro name="bar">'
                                     '<xacro:property name="foo" value="${21*factor}" scope="global"/></xacro:macro>'
                                     '<xacro:bar/></xacro:macro><xacro:foo factor="2"/><a foo="${foo}"/>')),
    "math_ignores_spaces": Case('<a><f v="${0.9 / 2 - 0.2}" /></a>'),
    "substitution_args_find": Case('<a><f v="$(find xacro)/test/test_xacro.py" /></a>'),
    "substitution_args_arg": Case('<a><f v="$(arg sub_arg)" /></a>', {"sub_arg": "my_arg"}),
    "escaping_dollar_braces": Case('<a b="$${foo}" c="$$${foo}" d="text $${foo}" e="text $$${foo}" f="$$(pwd)" />'),
    "just_a_dollar_sign": Case('<a b="$" c="text $" d="text $ text"/>'),
    "multiple_insert_blocks": Case(_a('<xacro:macro name="foo" params="*block"><xacro:insert_block name="block" />'
                                      '<xacro:insert_block name="block" /></xacro:macro><xacro:foo><a_block />'
                                      "</xacro:foo>")),
    "multiple_blocks-12": Case(_a('<xacro:macro name="foo" params="*block1 *block2"><xacro:insert_block '
                                  'name="block1" /><xacro:insert_block name="block2" /></xacro:macro>'
                                  "<xacro:foo><block1/><block2/></xacro:foo>")),
    "multiple_blocks-21": Case(_a('<xacro:macro name="foo" params="*block2 *block1"><xacro:insert_block '
                                  'name="block1" /><xacro:insert_block name="block2" /></xacro:macro>'
                                  "<xacro:foo><block1/><block2/></xacro:foo>")),
    "integer_stays_integer": Case(_a('<xacro:macro name="m" params="num"><test number="${num}" /></xacro:macro>'
                                     '<xacro:m num="100" />')),
    "insert_block_property": Case(_a('<xacro:macro name="bar">bar</xacro:macro><xacro:property name="val" '
                                     'value="2" /><xacro:property name="some_block"><some_block attr="${val}">'
                                     '<xacro:bar/></some_block></xacro:property><foo><xacro:insert_block '
                                     'name="some_block" /></foo>')),
    "include": Case(_a('<xacro:include filename="include1.xml" />')),
    "include_glob-star": Case(_a('<xacro:include filename="include*.xml"/>')),
    "include_glob-question": Case(_a('<xacro:include filename="include?.xml"/>')),
    "include_glob-range": Case(_a('<xacro:include filename="include[1-2].xml"/>')),
    "include_nonexistent": Case(_a('<xacro:include filename="include-nada.xml" />')),
    "include_deprecated": Case('<a><include filename="nada"><tag/></include></a>'),
    "include_from_variable": Case(_a('<xacro:property name="file" value="include1.xml"/>'
                                     '<xacro:include filename="${file}" />')),
    "include_recursive": Case(_a('<xacro:include filename="include1.xml"/><xacro:include filename="./include1.xml"/>'
                                 '<xacro:include filename="subdir/include-recursive.xacro"/>')),
    "include_with_namespace": Case(
        _a('<xacro:property name="var" value="main"/><xacro:include filename="include1.xacro" ns="A"/>'
           '<xacro:include filename="include2.xacro" ns="B"/><xacro:A.foo/><B.foo/>'
           '<main var="${var}" A="${2*A.var}" B="${B.var+1}"/>')),
    "boolean_if_statement": Case(_a('<xacro:if value="false"><a /></xacro:if><xacro:if value="true"><b /></xacro:if>',
                                    "robot")),
    "invalid_if_statement": Case(_a('<xacro:if value="nonsense"><foo/></xacro:if>')),
    "integer_if_statement": Case(_a('<xacro:if value="${0*42}"><a /></xacro:if><xacro:if value="0"><b /></xacro:if>'
                                    '<xacro:if value="${0}"><c /></xacro:if><xacro:if value="${1*2+3}"><d />'
                                    "</xacro:if>", "robot")),
    "float_if_statement": Case(_a('<xacro:if value="${3*0.0}"><a /></xacro:if><xacro:if value="${3*0.1}"><b />'
                                  "</xacro:if>", "robot")),
    "property_if_statement": Case(_a('<xacro:property name="condT" value="${True}"/><xacro:property name="condF" '
                                     'value="${False}"/><xacro:if value="${condF}"><a /></xacro:if><xacro:if '
                                     'value="${condT}"><b /></xacro:if><xacro:if value="${True}"><c /></xacro:if>',
                                     "robot")),
    "consecutive_if": Case(_a('<xacro:if value="1"><xacro:if value="0"><a>bar</a></xacro:if></xacro:if>')),
    "equality_expression_in_if_statement": Case(_a('<xacro:property name="var" value="useit"/><xacro:if '
                                                    'value="${var == \'useit\'}"><foo>bar</foo></xacro:if>'
                                                    '<xacro:if value="${\'use\' in var}"><bar>foo</bar></xacro:if>')),
    "no_evaluation": Case(_a('<xacro:property name="xyz" value="5 -2"/><foo>${xyz}</foo>')),
    "math_expressions": Case(_a('<foo function="${1. + sin(pi)}"/>')),
    "consider_non_elements_if": Case(_a('<xacro:if value="1"><!-- comment --> text <b>bar</b></xacro:if>')),
    "consider_non_elements_block": Case(_a('<xacro:macro name="foo" params="*block">\n  <!-- comment -->\n  foo\n'
                                           '  <xacro:insert_block name="block" />\n</xacro:macro>\n<xacro:foo>\n'
                                           "  <!-- ignored comment -->\n  ignored text\n  <a_block />\n</xacro:foo>\n")),
    "ignore_xacro_comments": Case(_a('\n  <!-- A -->\n\n  <!-- ignore multiline comments before any xacro tag -->\n'
                                     '  <!-- ignored -->\n  <xacro:property name="foo" value="1"/>\n  <!-- ignored -->\n'
                                     '  <xacro:if value="1"><!-- B --></xacro:if>\n  <!-- ignored -->\n'
                                     '  <xacro:macro name="foo"><!-- C --></xacro:macro>\n  <!-- ignored -->\n'
                                     "  <xacro:foo/>\n")),
    "recursive_evaluation": Case(_a('<xacro:property name="a" value=" 42 "/><xacro:property name="a2" '
                                    'value="${ 2 * a }"/><a doubled="${a2}"/>', "robot")),
    "recursive_evaluation_wrong_order": Case(_a('<xacro:property name="a2" value="${2*a}"/><xacro:property name="a" '
                                                'value="42"/><a doubled="${a2}"/>', "robot")),
    "recursive_definition": Case(_a('<xacro:property name="a" value="${a2}"/><xacro:property name="a2" '
                                    'value="${2*a}"/><a doubled="${a2}"/>', "robot")),
    "multiple_recursive_evaluation": Case(_a('<xacro:property name="a" value="1"/><xacro:property name="b" value="2"/>'
                                             '<xacro:property name="c" value="3"/><xacro:property name="product" '
                                             'value="${a*b*c}"/><answer product="${product}"/>', "robot")),
    "multiple_definition_and_evaluation": Case(_a('<xacro:property name="a" value="42"/><xacro:property name="b" '
                                                  'value="${a}"/><xacro:property name="b" value="${-a}"/>'
                                                  '<xacro:property name="b" value="${a}"/><answer b="${b} ${b} ${b}"/>',
                                                  "robot")),
    "transitive_evaluation": Case(_a('<xacro:property name="a" value="42"/><xacro:property name="b" value="${a}"/>'
                                     '<xacro:property name="c" value="${b}"/><xacro:property name="d" value="${c}"/>'
                                     '<answer d="${d}"/>', "robot")),
    "multi_tree_evaluation": Case(_a('<xacro:property name="a" value="42"/><xacro:property name="b" value="2.1"/>'
                                     '<xacro:property name="c" value="${a}"/><xacro:property name="d" value="${b}"/>'
                                     '<xacro:property name="f" value="${c*d}"/><answer f="${f}"/>', "robot")),
    "from_issue": Case(_a('<xacro:property name="x" value="42"/><xacro:property name="wheel_width" value="${x}"/>'
                          '<link name="my_link"><origin xyz="0 0 ${wheel_width/2}"/></link>', "robot")),
    "recursive_bad_math": Case(_a('<xacro:property name="x" value="0"/><tag badness="${1/x}"/>', "robot")),
    "default_param": Case(_a(
        '<xacro:macro name="fixed_link" params="parent_link:=base_link child_link *joint_pose">'
        '<link name="${child_link}"/><joint name="${child_link}_joint" type="fixed"><xacro:insert_block '
        'name="joint_pose" /><parent link="${parent_link}"/><child link="${child_link}" /></joint></xacro:macro>'
        '<xacro:fixed_link child_link="foo"><origin xyz="0 0 0" rpy="0 0 0" /></xacro:fixed_link >', "robot")),
    "default_param_override": Case(_a(
        '<xacro:macro name="fixed_link" params="parent_link:=base_link child_link *joint_pose">'
        '<link name="${child_link}"/><joint name="${child_link}_joint" type="fixed"><xacro:insert_block '
        'name="joint_pose" /><parent link="${parent_link}"/><child link="${child_link}" /></joint></xacro:macro>'
        '<xacro:fixed_link child_link="foo" parent_link="bar"><origin xyz="0 0 0" rpy="0 0 0" /></xacro:fixed_link >',
        "robot")),
    "param_missing": Case(_a(
        '<xacro:macro name="fixed_link" params="parent_link child_link *joint_pose"><link name="${child_link}"/>'
        '<joint name="${child_link}_joint" type="fixed"><xacro:insert_block name="joint_pose" />'
        '<parent link="${parent_link}"/><child link="${child_link}" /></joint></xacro:macro>'
        '<xacro:fixed_link child_link="foo"><origin xyz="0 0 0" rpy="0 0 0" /></xacro:fixed_link >', "robot")),
    "default_arg": Case(_a('<xacro:arg name="foo" default="2"/><link name="my_link"><origin xyz="0 0 $(arg foo)"/>'
                           "</link>", "robot")),
    "default_arg_override": Case(_a('<xacro:arg name="foo" default="2"/><link name="my_link"><origin '
                                    'xyz="0 0 $(arg foo)"/></link>', "robot"), {"foo": "4"}),
    "default_arg_missing": Case(_a('<a arg="$(arg foo)"/>')),
    "default_arg_empty": Case(_a('<xacro:arg name="foo" default=""/>$(arg foo)')),
    "iterable_literals_plain": Case(_a('<xacro:property name="list" value="[0, 1+1, 2]"/><xacro:property '
                                       'name="tuple" value="(0,1+1,2)"/><xacro:property name="dict" '
                                       'value="{\'a\':0, \'b\':1+1, \'c\':2}"/><a list="${list}" tuple="${tuple}" '
                                       'dict="${dict}"/>')),
    "iterable_literals_eval": Case(_a('<xacro:property name="list" value="${[0, 1+1, 2]}"/><xacro:property '
                                      'name="tuple" value="${(0,1+1,2)}"/><xacro:property name="dic" '
                                      'value="${dict(a=0, b=1+1, c=2)}"/><a list="${list}" tuple="${tuple}" '
                                      'dict="${dic}"/>')),
    "enforce_xacro_ns": Case(_a('<arg name="foo" value="bar"/><include filename="foo"/>')),
    "issue_68_numeric_arg": Case(_a('<xacro:arg name="foo" default="0.5"/><xacro:property name="prop" '
                                    'value="$(arg foo)" /><a prop="${prop-0.3}"/>')),
    "transitive_arg_evaluation": Case(_a('<xacro:arg name="foo" default="0.5"/><xacro:arg name="bar" '
                                         'default="$(arg foo)"/><xacro:property name="prop" value="$(arg bar)" />'
                                         '<a prop="${prop-0.3}"/>')),
    "macro_name_with_colon": Case(_a('<xacro:macro name="xacro:my_macro"><foo/></xacro:macro><xacro:my_macro/>')),
    "overwrite_globals": Case(_a('<xacro:property name="pi"  value="3.14"/>')),
    "no_double_evaluation": Case(_a('<xacro:macro name="foo" params="a b:=${a} c:=$${a}"> a=${a} b=${b} c=${c} '
                                    '</xacro:macro><xacro:property name="a" value="1"/><xacro:property name="d" '
                                    'value="$${a}"/><d d="${d}"><xacro:foo a="2"/></d>')),
    "property_forwarding": Case(_a('<xacro:property name="arg" value="42"/><xacro:macro name="foo" '
                                   'params="arg:=^">${arg}</xacro:macro><xacro:foo/>')),
    "property_forwarding-bar": Case(_a('<xacro:property name="arg" value="42"/><xacro:macro name="foo" '
                                       'params="arg:=^|">${arg}</xacro:macro><xacro:foo/>')),
    "property_forwarding-default": Case(_a('<xacro:property name="arg" value="42"/><xacro:macro name="foo" '
                                           'params="arg:=^|6">${arg}</xacro:macro><xacro:foo/>')),
    "extension_in_expression": Case(_a("${2*'$(arg var)'}"), {"var": "xacro"}),
    "expression_in_extension": Case(_a("$(arg ${'v'+'ar'})"), {"var": "xacro"}),
    "target_namespace": Case(f'<a {NS} xacro:targetNamespace="http://www.ros.org"/>'),
    "target_namespace_only_from_root": Case(_a('<b xacro:targetNamespace="http://www.ros.org"/>')),
    "include_lazy": Case(_a('<xacro:if value="false"><xacro:include filename="non-existent"/></xacro:if>')),
    "issue_63_fixed_with_inorder_processing": Case(_a(
        '<xacro:arg name="has_stuff" default="false"/><xacro:if value="$(arg has_stuff)"><xacro:include '
        'file="$(find nonexistent_package)/stuff.urdf" /></xacro:if>')),
    "include_from_macro": Case(_a(
        '<xacro:macro name="foo" params="file:=include1.xml"><xacro:include filename="${file}"/></xacro:macro>'
        "<xacro:foo/><xacro:foo file=\"${abs_filename('include1.xml')}\"/>"
        '<xacro:include filename="subdir/foo.xacro"/><xacro:foo file="$(cwd)/subdir/include1.xml"/>')),
    "yaml_support-inc1": Case(_a("<xacro:property name=\"settings\" value=\"${load_yaml('settings.yaml')}\"/>"
                                '<xacro:property name="type" value="$(arg type)"/>'
                                "<xacro:include filename=\"${settings['arms'][type]['file']}\"/>"
                                "<xacro:call macro=\"${settings['arms'][type]['macro']}\"/>"), {"type": "inc1"}),
    "yaml_support-inc2": Case(_a("<xacro:property name=\"settings\" value=\"${load_yaml('settings.yaml')}\"/>"
                                '<xacro:property name="type" value="$(arg type)"/>'
                                "<xacro:include filename=\"${settings['arms'][type]['file']}\"/>"
                                "<xacro:call macro=\"${settings['arms'][type]['macro']}\"/>"), {"type": "inc2"}),
    "yaml_support_dotted": Case(_a("<xacro:property name=\"settings\" value=\"${load_yaml('settings.yaml')}\"/>"
                                   '<xacro:property name="type" value="$(arg type)"/>'
                                   '<xacro:include filename="${settings.arms[type].file}"/>'
                                   '<xacro:call macro="${settings.arms[type].macro}"/>'), {"type": "inc1"}),
    "yaml_support_dotted_key_error": Case(_a("<xacro:property name=\"settings\" "
                                             "value=\"${load_yaml('settings.yaml')}\"/>"
                                             '<xacro:property name="bar" value="${settings.baz}"/>${bar}')),
    "yaml_support_dotted_arith": Case(_a("<xacro:property name=\"settings\" value=\"${load_yaml('settings.yaml')}\"/>"
                                         '<xacro:property name="bar" value="${settings.arms.inc2.props.port + 1}"/>'
                                         "${bar}")),
    "yaml_support_key_in_dict": Case(_a("<xacro:property name=\"settings\" value=\"${load_yaml('settings.yaml')}\"/>"
                                        "${'arms' in settings} ${'baz' in settings}")),
    "yaml_support_list_of_x": Case(_a("<xacro:property name=\"list\" value=\"${load_yaml('list.yaml')}\"/>"
                                      "${list[0][1]} ${list[1][0]} ${list[2].a.A} ${list[2].a.B[0]} "
                                      "${list[2].a.B[1]} ${list[2].b[0]}")),
    "yaml_custom_constructors": Case(_a("<xacro:property name=\"values\" value=\"${load_yaml('constructors.yaml')}\"/>"
                                        '<values a="${values.a}" b="${values.b}" c="${values.c}"/>')),
    "yaml_custom_constructors_illegal_expr": Case(_a(
        "<xacro:property name=\"values\" value=\"${load_yaml('constructors_bad.yaml')}\"/>"
        '<values a="${values.a}" />')),
    "macro_default_param_evaluation_order": Case(_a(
        '<xacro:macro name="foo" params="arg:=${2*foo}"><xacro:property name="foo" value="-"/><f val="${arg}"/>'
        '</xacro:macro><xacro:property name="foo" value="${3*7}"/><xacro:foo/><xacro:property name="foo" '
        'value="*"/><xacro:foo/>')),
    "check_order_warning": Case(_a('<xacro:property name="bar" value="unused"/><xacro:property name="foo" '
                                   'value="unused"/><xacro:macro name="foo" params="arg:=${foo}"><a val="${arg}"/>'
                                   '</xacro:macro><xacro:foo/><xacro:property name="bar" value="dummy"/>'
                                   '<xacro:property name="foo" value="21"/>')),
    "default_property": Case(_a('<xacro:property name="prop" default="false"/><xacro:unless value="${prop}"><foo/>'
                                '<xacro:property name="prop" value="true"/></xacro:unless><!-- second foo should be '
                                'ignored --><xacro:unless value="${prop}"><foo/><xacro:property name="prop" '
                                'value="true"/></xacro:unless>')),
    "unicode_literal_parsing": Case(_a("🍔 ")),
    "unicode_property": Case(_a('<xacro:property name="burger" value="🍔"/>${burger}')),
    "unicode_property_attribute": Case(_a('<xacro:property name="burger" value="🍔"/><b c="${burger}"/>')),
    "unicode_property_block": Case(_a('<xacro:property name="burger">\n🍔\n</xacro:property>'
                                      '<xacro:insert_block name="burger"/>')),
    "unicode_conditional": Case(_a('<xacro:property name="burger" value="🍔"/><xacro:if value="${burger == u\'🍔\'}">'
                                   "\n🍟\n</xacro:if>")),
    "unicode_macro": Case(_a('<xacro:macro name="burger" params="how_many">${u\'🍔\' * how_many}</xacro:macro>'
                             '<xacro:burger how_many="4"/>')),
    "macro_name_clash": Case(_a('<xacro:macro name="foo"><bar/></xacro:macro><foo/>')),
    # the three legacy cases above, in a robot description: there tfrec reads the Kinetic-era dialect
    "macro_name_clash-robot": Case(_a('<xacro:macro name="foo"><bar/></xacro:macro><foo/>', "robot"),
                                   legacy=_a('<xacro:macro name="foo"><bar/></xacro:macro><xacro:foo/>', "robot")),
    "include_with_namespace-robot": Case(
        _a('<xacro:property name="var" value="main"/><xacro:include filename="include1.xacro" ns="A"/>'
           '<xacro:include filename="include2.xacro" ns="B"/><xacro:A.foo/><B.foo/>'
           '<main var="${var}" A="${2*A.var}" B="${B.var+1}"/>', "robot"),
        legacy=_a('<xacro:property name="var" value="main"/><xacro:include filename="include1.xacro" ns="A"/>'
                  '<xacro:include filename="include2.xacro" ns="B"/><xacro:A.foo/><xacro:B.foo/>'
                  '<main var="${var}" A="${2*A.var}" B="${B.var+1}"/>', "robot")),
    "enforce_xacro_ns-robot": Case(_a('<arg name="foo" value="bar"/><include filename="foo"/>', "robot"),
                                   legacy=_a('<arg name="foo" value="bar"/><xacro:include filename="foo"/>', "robot")),
    "invalid_syntax-open-expr": Case("<a>a${</a>"),
    "invalid_syntax-unclosed-expr": Case("<a>${b</a>"),
    "invalid_syntax-braces": Case("<a>${{}}</a>"),
    "invalid_syntax-open-extension": Case("<a>a$(</a>"),
    "invalid_syntax-unclosed-extension": Case("<a>$(b</a>"),
}

FILES: dict[str, str] = {
    "include1.xml": "<a><inc1/></a>\n",
    "include2.xml": "<a><inc2/></a>\n",
    "include1.xacro": f'<a {NS}>\n\t<xacro:property name="var" value="1"/>\n\t<xacro:macro name="foo"><inc1/>'
                      "</xacro:macro>\n\t<xacro:macro name=\"foo1\"><inc1/></xacro:macro>\n</a>\n",
    "include2.xacro": f'<a {NS}>\n\t<xacro:property name="var" value="2"/>\n\t<xacro:macro name="foo"><inc2/>'
                      "</xacro:macro>\n\t<xacro:macro name=\"foo2\"><inc2/></xacro:macro>\n</a>\n",
    "subdir/include1.xml": "<a><subdir_inc1/></a>\n",
    "subdir/include-recursive.xacro": f'<a {NS}>\n    <xacro:include filename="include1.xml"/>\n'
                                      '    <xacro:include filename="./include1.xml"/>\n'
                                      '    <xacro:include filename="$(cwd)/include1.xml"/>\n</a>\n',
    "subdir/foo.xacro": f"<a {NS}/>\n",
    "settings.yaml": "arms:\n  inc1:\n    file:  include1.xacro\n    macro: foo1\n  inc2:\n    file:  include2.xacro\n"
                     "    macro: foo2\n    props:\n      port: 4242\n",
    "list.yaml": "---\n- - A1\n  - A2\n- - B1\n- a: { A: 1, B: [2, 3] }\n  b: B\n",
    "constructors.yaml": "a: !degrees 180\nb: !radians 0.5*pi\nc: 42\n",
    "constructors_bad.yaml": "a: !degrees 180deg\n",
}
"""The suite's support files, as its tests expect them."""
