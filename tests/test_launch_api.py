"""Upstream's launch API, name for name: what a launch file written for a full ROS 2 Jazzy
install imports exists here with upstream's signature and behaviour, and XML and YAML
launch files read into the same actions (their mistakes named in one line).

Nothing here starts a process; ``test_launch_tutorials`` runs the tutorials' files.
"""

from __future__ import annotations

import importlib
import inspect
import sys
from pathlib import Path
from typing import Any

import pytest

from rosbook.launch.launcher import (
    Launch,
    LaunchDescription,
    LaunchError,
    format_launch_description,
    load_launch_file,
)
from rosbook.launch.substitutions import LaunchContext, parse_substitution, perform_substitutions

#: The public names (``__all__``) of upstream's jazzy packages, read from
#: github.com/ros2/launch (launch, launch_xml, launch_yaml) and github.com/ros2/launch_ros,
#: branch jazzy, the ``__init__.py`` of each module named here.
UPSTREAM_JAZZY_NAMES = {
    "launch": [
        "actions", "conditions", "descriptions", "events", "frontend", "logging",
        "substitutions", "Action", "Condition", "Event", "EventHandler",
        "InvalidLaunchFileError", "LaunchContext", "LaunchDescription",
        "LaunchDescriptionEntity", "LaunchDescriptionSource", "LaunchIntrospector",
        "LaunchService", "SomeEntitiesType", "SomeEntitiesType_types_tuple",
        "SomeSubstitutionsType", "SomeSubstitutionsType_types_tuple", "Substitution",
    ],
    "launch.actions": [
        "AppendEnvironmentVariable", "DeclareLaunchArgument", "EmitEvent", "ExecuteLocal",
        "ExecuteProcess", "GroupAction", "IncludeLaunchDescription", "LogInfo",
        "OpaqueCoroutine", "OpaqueFunction", "PopEnvironment", "PopLaunchConfigurations",
        "PushEnvironment", "PushLaunchConfigurations", "ResetEnvironment",
        "ResetLaunchConfigurations", "RegisterEventHandler", "SetEnvironmentVariable",
        "SetLaunchConfiguration", "Shutdown", "TimerAction", "UnregisterEventHandler",
        "UnsetEnvironmentVariable", "UnsetLaunchConfiguration",
    ],
    "launch.substitutions": [
        "AllSubstitution", "AndSubstitution", "AnySubstitution", "AnonName", "Command",
        "EqualsSubstitution", "EnvironmentVariable", "FileContent", "FindExecutable",
        "IfElseSubstitution", "LaunchConfiguration", "LaunchLogDir", "LocalSubstitution",
        "NotSubstitution", "NotEqualsSubstitution", "OrSubstitution", "PathJoinSubstitution",
        "PythonExpression", "SubstitutionFailure", "TextSubstitution", "ThisLaunchFile",
        "ThisLaunchFileDir",
    ],
    "launch.conditions": [
        "evaluate_condition_expression", "IfCondition", "InvalidConditionExpressionError",
        "LaunchConfigurationEquals", "LaunchConfigurationNotEquals", "UnlessCondition",
    ],
    "launch.event_handlers": [
        "event_named", "OnExecutionComplete", "OnIncludeLaunchDescription", "OnProcessExit",
        "OnProcessIO", "OnProcessStart", "OnShutdown",
    ],
    "launch.events": [
        "matches_action", "process", "ExecutionComplete", "IncludeLaunchDescription",
        "Shutdown", "TimerEvent",
    ],
    "launch.events.process": [
        "matches_executable", "matches_name", "matches_pid", "ProcessExited", "ProcessIO",
        "ProcessStarted", "ProcessStderr", "ProcessStdin", "ProcessStdout",
        "ProcessTargetedEvent", "RunningProcessEvent", "ShutdownProcess", "SignalProcess",
    ],
    "launch.launch_description_sources": [
        "get_launch_description_from_any_launch_file",
        "get_launch_description_from_python_launch_file",
        "get_launch_description_from_frontend_launch_file", "InvalidFrontendLaunchFileError",
        "InvalidLaunchFileError", "InvalidPythonLaunchFileError",
        "load_python_launch_file_as_module", "AnyLaunchDescriptionSource",
        "FrontendLaunchDescriptionSource", "PythonLaunchDescriptionSource",
    ],
    "launch.descriptions": ["Executable"],
    "launch_ros": [
        "actions", "descriptions", "event_handlers", "events", "ros_adapters", "substitutions",
    ],
    "launch_ros.actions": [
        "ComposableNodeContainer", "LifecycleNode", "LifecycleTransition",
        "LoadComposableNodes", "Node", "PushROSNamespace", "PushRosNamespace", "ROSTimer",
        "RosTimer", "SetParameter", "SetParametersFromFile", "SetRemap", "SetROSLogDir",
        "SetUseSimTime",
    ],
    "launch_ros.substitutions": [
        "ExecutableInPackage", "FindPackage", "FindPackagePrefix", "FindPackageShare",
        "Parameter",
    ],
    "launch_ros.descriptions": ["ComposableNode", "Parameter", "ParameterFile", "ParameterValue"],
    "launch_ros.events": ["lifecycle", "matches_node_name"],
    "launch_ros.events.lifecycle": ["ChangeState", "matches_node_name", "StateTransition"],
    "launch_ros.event_handlers": ["OnStateTransition"],
    "launch_xml": ["launch_description_sources", "Entity", "Parser"],
    "launch_xml.launch_description_sources": ["XMLLaunchDescriptionSource"],
    "launch_yaml": ["launch_description_sources", "Entity", "Parser"],
    "launch_yaml.launch_description_sources": ["YAMLLaunchDescriptionSource"],
}  # fmt: skip


@pytest.mark.parametrize("module", sorted(UPSTREAM_JAZZY_NAMES))
def test_every_public_name_of_upstream_jazzy_launch_and_launch_ros_exists(module: str) -> None:
    imported = importlib.import_module(module)
    missing = [name for name in UPSTREAM_JAZZY_NAMES[module] if not hasattr(imported, name)]
    assert not missing, f"{module} lacks {missing}"


def shape(target: Any) -> str:
    """A callable's parameters as written, without annotations: ``a, *, b='x', **kw``."""
    parameters = list(inspect.signature(target).parameters.values())
    if parameters and parameters[0].name == "self":
        parameters = parameters[1:]
    parts: list[str] = []
    starred = False
    for p in parameters:
        if p.kind is p.KEYWORD_ONLY and not starred:
            parts.append("*")
            starred = True
        prefix = {p.VAR_POSITIONAL: "*", p.VAR_KEYWORD: "**"}.get(p.kind, "")
        starred = starred or p.kind is p.VAR_POSITIONAL
        default = "" if p.default is p.empty else f"={p.default!r}"
        parts.append(f"{prefix}{p.name}{default}")
    return ", ".join(parts)


#: Signatures as upstream's jazzy sources declare them (parameter names, defaults,
#: keyword-only-ness); ``**kwargs`` take the common ``condition=``.
UPSTREAM_SIGNATURES = {
    "launch.actions.EmitEvent": "*, event, **kwargs",
    "launch.actions.OpaqueFunction": "*, function, args=None, kwargs=None, **left_over_kwargs",
    "launch.actions.SetEnvironmentVariable": "name, value, **kwargs",
    "launch.actions.AppendEnvironmentVariable": (
        "name, value, prepend=False, separator=':', **kwargs"
    ),
    "launch.actions.UnsetEnvironmentVariable": "name, **kwargs",
    "launch.actions.TimerAction": "*, period, actions, cancel_on_shutdown=True, **kwargs",
    "launch.actions.GroupAction": (
        "actions, *, scoped=True, forwarding=True, launch_configurations=None, **kwargs"
    ),
    "launch.actions.LogInfo": "*, msg, **kwargs",
    "launch.actions.Shutdown": "*, reason='reason not given', **kwargs",
    "launch.actions.RegisterEventHandler": "event_handler, **kwargs",
    "launch.actions.DeclareLaunchArgument": (
        "name, *, default_value=None, description=None, choices=None, **kwargs"
    ),
    "launch.actions.IncludeLaunchDescription": (
        "launch_description_source, *, launch_arguments=None, **kwargs"
    ),
    "launch.events.Shutdown": "*, reason='reason not given', due_to_sigint=False",
    "launch.event_handlers.OnProcessIO": (
        "*, target_action=None, on_stdin=None, on_stdout=None, on_stderr=None, **kwargs"
    ),
    "launch.event_handlers.OnExecutionComplete": "*, target_action=None, on_completion, **kwargs",
    "launch.event_handlers.OnProcessStart": "*, target_action=None, on_start, **kwargs",
    "launch.event_handlers.OnProcessExit": "*, target_action=None, on_exit, **kwargs",
    "launch.event_handlers.OnShutdown": "*, on_shutdown, **kwargs",
    "launch.substitutions.Command": "command, *, on_stderr='fail'",
    "launch.substitutions.LocalSubstitution": "expression, description=None",
    "launch.substitutions.FileContent": "path",
    "launch.substitutions.AndSubstitution": "left, right",
    "launch.substitutions.NotSubstitution": "value",
    "launch.substitutions.EqualsSubstitution": "left, right",
    "launch.substitutions.AllSubstitution": "*args",
    "launch.substitutions.IfElseSubstitution": "condition, if_value='', else_value=''",
    "launch.substitutions.FindExecutable": "*, name",
    "launch.substitutions.LaunchConfiguration": "variable_name, *, default=None",
    "launch.conditions.LaunchConfigurationEquals": ("launch_configuration_name, expected_value"),
    "launch_ros.actions.LifecycleNode": "*, name, namespace, **kwargs",
    "launch_ros.actions.SetRemap": "src, dst, **kwargs",
    "launch_ros.actions.PushROSNamespace": "namespace, **kwargs",
    "launch_ros.actions.ComposableNodeContainer": (
        "*, name, namespace, composable_node_descriptions=None, **kwargs"
    ),
    "launch_ros.actions.LoadComposableNodes": (
        "*, composable_node_descriptions, target_container, **kwargs"
    ),
    "launch_ros.actions.LifecycleTransition": ("*, lifecycle_node_names, transition_ids, **kwargs"),
    "launch_ros.descriptions.ComposableNode": (
        "*, package, plugin, name=None, namespace=None, parameters=None, remappings=None, "
        "extra_arguments=None, condition=None"
    ),
    "launch_ros.descriptions.ParameterFile": "param_file, *, allow_substs=False",
    "launch_ros.descriptions.ParameterValue": "value, *, value_type=None",
    "launch_ros.descriptions.Parameter": "name, value, *, value_type=None",
    "launch_ros.events.lifecycle.ChangeState": "*, lifecycle_node_matcher, transition_id",
    "launch_ros.event_handlers.OnStateTransition": (
        "*, entities, target_lifecycle_node=None, transition=None, start_state=None, "
        "goal_state=None, matcher=None, **kwargs"
    ),
    "launch_ros.substitutions.ExecutableInPackage": "executable, package",
}


@pytest.mark.parametrize("dotted", sorted(UPSTREAM_SIGNATURES))
def test_signatures_are_upstreams(dotted: str) -> None:
    module, _, name = dotted.rpartition(".")
    assert shape(getattr(importlib.import_module(module), name)) == UPSTREAM_SIGNATURES[dotted]


def test_execute_process_and_node_take_upstreams_process_options() -> None:
    from launch.actions import ExecuteProcess
    from launch_ros.actions import Node

    node = Node(package="robot_talk", executable="talker", respawn=True, respawn_delay=2.0)
    assert (node.respawn, node.respawn_delay, node.respawn_max_retries) == (True, 2.0, -1)
    process = ExecuteProcess(cmd=["true"], prefix="nice -n 5", cached_output=True, log_cmd=True)
    context = LaunchContext()
    assert perform_substitutions(context, process.prefix) == "nice -n 5"


def perform(value: Any, **configurations: str) -> str:
    context = LaunchContext({"HOME": "/home/ada"})
    context.launch_configurations.update(configurations)
    return perform_substitutions(context, value)


def test_boolean_and_equality_substitutions_compare_as_upstream() -> None:
    from launch.substitutions import (
        AllSubstitution,
        AndSubstitution,
        AnySubstitution,
        EqualsSubstitution,
        IfElseSubstitution,
        LaunchConfiguration,
        NotEqualsSubstitution,
        NotSubstitution,
        OrSubstitution,
    )

    use = LaunchConfiguration("use")
    assert perform(AndSubstitution(use, "1"), use="true") == "true"
    assert perform(OrSubstitution(use, "false"), use="False") == "false"
    assert perform(NotSubstitution(use), use="0") == "true"
    assert perform(AllSubstitution("true", "1", use), use="true") == "true"
    assert perform(AnySubstitution("false", use), use="false") == "false"
    assert perform(EqualsSubstitution(LaunchConfiguration("rate"), 2.0), rate="2") == "true"
    assert perform(EqualsSubstitution(use, True), use="1") == "true"  # booleans by value
    assert perform(EqualsSubstitution("robot1", "robot2")) == "false"
    assert perform(NotEqualsSubstitution(use, None), use="") == "false"
    assert perform(IfElseSubstitution(use, "on", "off"), use="false") == "off"
    with pytest.raises(LaunchError, match="'maybe' is not a boolean"):
        perform(NotSubstitution(use), use="maybe")


def test_launch_configuration_conditions_compare_the_text() -> None:
    from launch.conditions import LaunchConfigurationEquals, LaunchConfigurationNotEquals

    context = LaunchContext()
    context.launch_configurations["mode"] = "sim"
    assert LaunchConfigurationEquals("mode", "sim").evaluate(context)
    assert LaunchConfigurationNotEquals("mode", "real").evaluate(context)
    assert LaunchConfigurationEquals("unset", None).evaluate(context)
    assert not LaunchConfigurationEquals("mode", None).evaluate(context)


def test_command_file_content_and_path_substitutions(tmp_path: Path) -> None:
    from launch.substitutions import (
        Command,
        FileContent,
        LaunchConfiguration,
        PathJoinSubstitution,
        PathSubstitution,
    )

    robot = tmp_path / "robot.urdf"
    robot.write_text("<robot name='r'/>")
    python = sys.executable
    assert perform(Command([python, " -c 'print(40 + 2)'"])) == "42\n"
    assert perform(FileContent(PathSubstitution(robot))) == "<robot name='r'/>"
    joined = PathSubstitution(tmp_path) / LaunchConfiguration("name")
    assert isinstance(joined, PathJoinSubstitution)
    assert perform(joined, name="robot.urdf") == str(robot)
    with pytest.raises(LaunchError, match="executed command failed. Command: false"):
        perform(Command("false"))
    with pytest.raises(LaunchError, match="executed command showed stderr output"):
        perform(Command([python, " -c 'import sys; sys.stderr.write(\"oops\")'"]))
    assert perform(Command("sh -c 'echo out; echo err >&2'", on_stderr="ignore")) == "out\n"
    with pytest.raises(LaunchError, match="File not found: /nonexistent"):
        perform(FileContent("/nonexistent"))


def test_opaque_function_environment_and_configuration_actions_apply_in_order() -> None:
    from launch.actions import (
        AppendEnvironmentVariable,
        OpaqueFunction,
        PopEnvironment,
        PopLaunchConfigurations,
        PushEnvironment,
        PushLaunchConfigurations,
        SetEnvironmentVariable,
        SetLaunchConfiguration,
        UnsetLaunchConfiguration,
    )

    seen: list[tuple[str | None, str | None]] = []

    def record(context: LaunchContext) -> None:
        seen.append((context.environment.get("ROBOT"), context.launch_configurations.get("mode")))

    look = OpaqueFunction(function=record)
    description = LaunchDescription(
        [
            SetEnvironmentVariable("ROBOT", "r1"),
            AppendEnvironmentVariable("ROBOT", "r2", separator=","),
            SetLaunchConfiguration("mode", "sim"),
            look,
            PushEnvironment(),
            PushLaunchConfigurations(),
            SetEnvironmentVariable("ROBOT", "other"),
            UnsetLaunchConfiguration("mode"),
            look,
            PopEnvironment(),
            PopLaunchConfigurations(),
            look,
            OpaqueFunction(function=lambda context, text: [look] * len(text), args=["ab"]),
        ]
    )
    Launch(description, env={}, echo=None)
    assert seen == [("r1,r2", "sim"), ("other", None), ("r1,r2", "sim")] + [("r1,r2", "sim")] * 2


def test_emit_event_shutdown_runs_on_shutdown_with_the_reason_as_a_local() -> None:
    from launch.actions import EmitEvent, LogInfo, RegisterEventHandler
    from launch.event_handlers import OnExecutionComplete, OnShutdown
    from launch.events import Shutdown
    from launch.substitutions import LocalSubstitution

    note = LogInfo(msg="before")
    description = LaunchDescription(
        [
            RegisterEventHandler(
                OnShutdown(
                    on_shutdown=[LogInfo(msg=["asked: ", LocalSubstitution("event.reason")])]
                )
            ),
            RegisterEventHandler(
                OnExecutionComplete(target_action=note, on_completion=[LogInfo(msg="after")])
            ),
            note,
            EmitEvent(event=Shutdown(reason="Window closed")),
        ]
    )
    system = Launch(description, env={}, echo=None)
    system.pump()
    assert system.output == [
        "[INFO] [launch.user]: before",
        "[INFO] [launch.user]: after",
        "[INFO] [launch]: shutting down: Window closed",
        "[INFO] [launch.user]: asked: Window closed",
    ]


def test_composable_nodes_describe_and_refuse_to_run_in_one_sentence() -> None:
    from launch_ros.actions import ComposableNodeContainer, LoadComposableNodes
    from launch_ros.descriptions import ComposableNode

    nodes = [ComposableNode(package="composition", plugin="composition::Talker", name="talker")]
    container = ComposableNodeContainer(
        name="container",
        namespace="",
        package="rclcpp_components",
        executable="component_container",
        composable_node_descriptions=nodes,
    )
    load = LoadComposableNodes(composable_node_descriptions=nodes, target_container=container)
    description = LaunchDescription([container, load])
    assert description.describe_sub_entities() == [container, load]  # it loads and describes
    walked = format_launch_description(description)
    assert "ComposableNodeContainer" in walked and "LoadComposableNodes" in walked
    for action in (container, load):
        with pytest.raises(LaunchError) as refused:
            Launch(LaunchDescription([action]), env={}, echo=None)
        message = str(refused.value)
        assert "needs C++ components" in message and "composition::Talker" in message
        assert "\n" not in message and message.count(". ") == 0


def test_frontend_substitutions_nest_and_quote_as_upstream() -> None:
    context = LaunchContext({"HOME": "/home/ada"})
    context.launch_configurations.update(rate="2", pkg="robot_talk")

    def text(source: str) -> str:
        return perform_substitutions(context, parse_substitution(source))

    assert text("$(var rate)Hz") == "2Hz"
    assert text("$(eval '$(var rate) * 2')") == "4"
    assert text("$(env HOME)/ws") == "/home/ada/ws"
    assert text("$(env NOT_SET fallback)") == "fallback"
    assert text("$(var missing 'a default')") == "a default"
    assert text("$(not $(equals $(var rate) 2.0))") == "false"
    with pytest.raises(LaunchError, match=r"unknown substitution '\$\(find-pkg \.\.\.\)'"):
        parse_substitution("$(find-pkg robot_talk)")
    with pytest.raises(LaunchError, match="is not closed"):
        parse_substitution("$(var rate")


XML = """\

<?xml version="1.0"?>
<launch>
  <arg name="rate" default="2.0" description="Hz"/>
  <arg name="robot" default="robot1">
    <choice value="robot1"/>
    <choice value="robot2"/>
  </arg>
  <let name="greeting" value="hello $(var robot)"/>
  <group>
    <push-ros-namespace namespace="$(var robot)"/>
    <set-env name="SITE" value="lab"/>
    <node pkg="robot_talk" exec="talker" name="talker" respawn="true" respawn_delay="1.5"
          args="--flag $(var rate)" unless="$(eval '$(var rate) &gt; 10')">
      <param name="rate" value="$(var rate)"/>
      <param name="limits">
        <param name="max" value="3"/>
      </param>
      <remap from="chatter" to="news"/>
      <env name="MODE" value="fast"/>
    </node>
  </group>
  <executable cmd="echo $(var greeting)" output="screen" if="true"/>
  <include file="$(dirname)/other.launch.yaml">
    <arg name="x" value="1"/>
  </include>
</launch>
"""


def test_an_xml_launch_file_reads_into_the_actions_of_a_python_one(tmp_path: Path) -> None:
    from launch.actions import (
        DeclareLaunchArgument,
        ExecuteProcess,
        GroupAction,
        IncludeLaunchDescription,
        SetLaunchConfiguration,
    )
    from launch_ros.actions import Node, PushROSNamespace

    path = tmp_path / "robot.launch.xml"
    path.write_text(XML)
    description = load_launch_file(path)
    rate, robot, let, group, echo, include = description.entities
    assert isinstance(rate, DeclareLaunchArgument) and rate.description == "Hz"
    assert robot.choices == ["robot1", "robot2"]
    assert isinstance(let, SetLaunchConfiguration) and isinstance(group, GroupAction)
    push, set_env, node = group.actions
    assert isinstance(push, PushROSNamespace) and isinstance(node, Node)
    assert isinstance(echo, ExecuteProcess) and isinstance(include, IncludeLaunchDescription)
    context = LaunchContext({"HOME": "/h"})
    context.launch_configurations.update(rate="2.0", robot="robot2", greeting="hi")
    assert (node.respawn, node.respawn_delay) == (True, 1.5)
    assert [perform_substitutions(context, a) for a in node.arguments] == ["--flag", "2.0"]
    assert node.condition.evaluate(context)  # unless rate > 10: it runs
    assert echo.command(context) == ["echo", "hi"]
    assert {k: perform_substitutions(context, v) for k, v in node.additional_env.items()} == {
        "MODE": "fast"
    }
    params = [p.evaluate(context) for p in node.parameters]
    assert params == [("rate", 2.0), ("limits.max", 3)]


YAML = """\
launch:
- arg: {name: rate, default: 2.0}
- group:
  - push_ros_namespace: {namespace: robot1}
  - node:
      pkg: robot_talk
      exec: talker
      name: talker
      param:
      - {name: rate, value: "$(var rate)"}
      remap:
      - {from: chatter, to: news}
- executable: {cmd: "echo $(var rate)", output: screen}
"""


def test_a_yaml_launch_file_reads_into_the_same_actions(tmp_path: Path) -> None:
    from launch_ros.actions import Node

    path = tmp_path / "robot.launch.yaml"
    path.write_text(YAML)
    arg, group, echo = load_launch_file(path).entities
    context = LaunchContext()
    context.launch_configurations["rate"] = "2.0"
    assert perform_substitutions(context, arg.default_value) == "2.0"
    node = group.actions[1]
    assert isinstance(node, Node)
    assert [p.evaluate(context) for p in node.parameters] == [("rate", 2.0)]
    assert [tuple(perform_substitutions(context, s) for s in r) for r in node.remappings] == [
        ("chatter", "news")
    ]
    assert echo.command(context) == ["echo", "2.0"]


@pytest.mark.parametrize(
    ("suffix", "text", "message"),
    [
        (".xml", "<launch>\n  <nod pkg='a' exec='b'/>\n</launch>", r":2: <nod> is not a launch"),
        (
            ".xml",
            "<launch>\n\n  <node pakage='a' exec='b'/>\n</launch>",
            r":3: <node> has no attribute 'pakage'",
        ),
        (
            ".xml",
            "<launch>\n  <node pkg='a'/>\n</launch>",
            r":2: <node> needs the attribute 'exec'",
        ),
        (".xml", "<launch>\n  <node exec='b'>\n</launch>", r"not well-formed XML: mismatched tag"),
        (
            ".xml",
            "<launch><node exec='b'><parm name='x' value='1'/></node></launch>",
            r"<parm> is not an element <node> can hold",
        ),
        (
            ".xml",
            "<launch><log message='$(vars x)'/></launch>",
            r"<log> attribute 'message': unknown substitution '\$\(vars \.\.\.\)'",
        ),
        (".xml", "<robot name='r'/>", r"<robot> is not <launch>"),
        (".yaml", "launch:\n- node: {pkg: a}\n", r"launch\[0\]\.node: <node> needs the attribute"),
        (".yaml", "nodes: []\n", r"a YAML launch file is a mapping with the key 'launch'"),
        (".yaml", "launch:\n- node: [\n", r"not valid YAML"),
    ],
)
def test_a_mistake_in_an_xml_or_yaml_launch_file_is_one_line_naming_the_element(
    tmp_path: Path, suffix: str, text: str, message: str
) -> None:
    path = tmp_path / f"broken.launch{suffix}"
    path.write_text(text)
    with pytest.raises(LaunchError, match=message) as raised:
        load_launch_file(path)
    assert "\n" not in str(raised.value) and str(path) in str(raised.value)


def test_a_robot_description_parameter_from_a_command_reaches_the_command_line(
    tmp_path: Path,
) -> None:
    from launch.substitutions import Command, PathJoinSubstitution
    from launch_ros.actions import Node
    from launch_ros.parameter_descriptions import ParameterValue

    urdf = tmp_path / "robot.urdf"
    urdf.write_text('<robot name="r">\n  <link name="base"/>\n</robot>\n')
    description = ParameterValue(
        Command(["cat ", PathJoinSubstitution([str(tmp_path), "robot.urdf"])]), value_type=str
    )
    node = Node(
        executable="/bin/true",
        parameters=[{"robot_description": description, "publish_frequency": 20.0}],
    )
    cmd = node.command(LaunchContext())
    assert cmd[cmd.index("-p") + 1] == (
        'robot_description:="<robot name=\\"r\\">\\n  <link name=\\"base\\"/>\\n</robot>\\n"'
    )
    assert "publish_frequency:=20.0" in cmd


def test_a_shutdown_while_the_description_is_visited_starts_nothing() -> None:
    from launch.actions import ExecuteProcess, Shutdown
    from launch.conditions import LaunchConfigurationEquals

    description = LaunchDescription(
        [
            Shutdown(reason="no robot", condition=LaunchConfigurationEquals("robot", None)),
            ExecuteProcess(cmd=["sleep", "600"]),
        ]
    )
    system = Launch(description, env={}, echo=None).start()
    try:
        assert system.processes == [] and system.shutting_down == "no robot"
    finally:
        system.shutdown()


def test_the_formats_pages_python_file_includes_xml_and_yaml_by_their_sources(
    tmp_path: Path,
) -> None:
    from launch.actions import IncludeLaunchDescription
    from launch_xml.launch_description_sources import XMLLaunchDescriptionSource
    from launch_yaml.launch_description_sources import YAMLLaunchDescriptionSource

    (tmp_path / "a.launch.xml").write_text("<launch><log message='from xml'/></launch>")
    (tmp_path / "a.launch.yaml").write_text("launch:\n- log: {message: from yaml}\n")
    description = LaunchDescription(
        [
            IncludeLaunchDescription(XMLLaunchDescriptionSource(str(tmp_path / "a.launch.xml"))),
            IncludeLaunchDescription(YAMLLaunchDescriptionSource(str(tmp_path / "a.launch.yaml"))),
        ]
    )
    system = Launch(description, env={}, echo=None)
    system.pump()
    assert system.output == ["[INFO] [launch.user]: from xml", "[INFO] [launch.user]: from yaml"]


def test_a_non_forwarding_group_keeps_only_what_it_is_given(tmp_path: Path) -> None:
    path = tmp_path / "keep.launch.xml"
    path.write_text(
        "<launch>\n"
        '  <let name="a" value="1"/>\n'
        '  <let name="b" value="2"/>\n'
        '  <group forwarding="false">\n'
        '    <keep name="a" value="$(var a)"/>\n'
        "    <log message=\"a=$(var a) b=$(var b 'unset')\"/>\n"
        "  </group>\n"
        '  <log message="b=$(var b)"/>\n'
        "</launch>\n"
    )
    system = Launch(load_launch_file(path), env={}, echo=None)
    system.pump()
    assert system.output == ["[INFO] [launch.user]: a=1 b=unset", "[INFO] [launch.user]: b=2"]


def test_an_opaque_function_registers_handlers_and_emits_events_through_its_context() -> None:
    from launch.actions import LogInfo, OpaqueFunction
    from launch.event_handlers import OnShutdown
    from launch.events import Shutdown

    def wire(context: LaunchContext) -> None:
        assert not context.is_shutdown
        context.register_event_handler(OnShutdown(on_shutdown=[LogInfo(msg="handled")]))
        context.emit_event_sync(Shutdown(reason="from a function"))

    system = Launch(LaunchDescription([OpaqueFunction(function=wire)]), env={}, echo=None)
    system.pump()
    assert system.output == [
        "[INFO] [launch]: shutting down: from a function",
        "[INFO] [launch.user]: handled",
    ]
