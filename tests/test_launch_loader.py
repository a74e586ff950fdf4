"""roslaunch XML into a plan: args and includes, namespaces, if/unless, params, rosparam, remaps and env,
against roslaunch's rules for names (rosgraph.names) and args (xmlloader)."""

from __future__ import annotations

from pathlib import Path

import pytest

from racecar_sim.description import expand_xacro
from racecar_sim.description.urdf import parse_urdf
from racecar_sim.launch import LaunchError, load_launch


def write(folder: Path, name: str, body: str) -> Path:
    path = folder / name
    path.write_text(f"<?xml version='1.0'?>\n<launch>\n{body}\n</launch>\n")
    return path


def test_include_args_namespaces_and_command_line_override(tmp_path):
    write(
        tmp_path,
        "inner.launch",
        """
      <arg name="speed"/>
      <arg name="label" default="inner"/>
      <param name="speed" value="$(arg speed)"/>
      <param name="label" value="$(arg label)"/>
      <node name="n" pkg="p" type="t"/>""",
    )
    top = write(
        tmp_path,
        "top.launch",
        """
      <arg name="speed" default="1.5"/>
      <group ns="car1"><include file="$(dirname)/inner.launch">
        <arg name="speed" value="$(arg speed)"/></include></group>
      <group ns="car2"><include file="$(dirname)/inner.launch" ns="deeper">
        <arg name="speed" value="$(eval speed * 2)"/><arg name="label" value="two"/></include></group>
      <include file="$(dirname)/inner.launch" ns="/abs" pass_all_args="true"/>""",
    )
    plan = load_launch(top)
    assert plan.params == {
        "/car1/speed": 1.5,
        "/car1/label": "inner",
        "/car2/deeper/speed": 3.0,
        "/car2/deeper/label": "two",
        "/abs/speed": 1.5,
        "/abs/label": "inner",
    }
    assert [n.full_name for n in plan.nodes] == ["/car1/n", "/car2/deeper/n", "/abs/n"]
    plan = load_launch(top, {"speed": "0.5"})
    assert plan.params["/car1/speed"] == 0.5 and plan.params["/car2/deeper/speed"] == 1.0
    assert plan.args == {"speed": "0.5"}


def test_arg_rules(tmp_path):
    fixed = write(tmp_path, "fixed.launch", '<arg name="a" value="1"/>')
    with pytest.raises(LaunchError, match="fixed value= and cannot be set"):
        load_launch(fixed, {"a": "2"})
    with pytest.raises(LaunchError, match=r"args? b given on the command line .* not declared"):
        load_launch(fixed, {"b": "2"})
    needed = write(tmp_path, "needed.launch", '<arg name="a"/>')
    with pytest.raises(
        LaunchError,
        match=r"needed.launch:3: <arg name=\"a\">: arg 'a' has no value; give it on the "
        r"command line as a:=VALUE",
    ):
        load_launch(needed)
    assert load_launch(needed, {"a": "x"}).args == {"a": "x"}
    twice = write(tmp_path, "twice.launch", '<arg name="a" default="1"/>\n<arg name="a" default="2"/>')
    with pytest.raises(LaunchError, match="declared twice"):
        load_launch(twice)
    scoped = write(
        tmp_path, "scoped.launch", '<group><arg name="g" default="1"/></group>\n<param name="p" value="$(arg g)"/>'
    )
    with pytest.raises(LaunchError, match="no arg 'g'"):  # an arg declared in a group is the group's own
        load_launch(scoped)


def test_if_and_unless_on_any_element(tmp_path):
    path = write(
        tmp_path,
        "cond.launch",
        """
      <arg name="on" default="true"/>
      <param name="a" value="1" if="$(arg on)"/>
      <param name="b" value="1" unless="$(arg on)"/>
      <group if="$(eval not on)"><param name="c" value="1"/></group>
      <node name="n" pkg="p" type="t" unless="$(arg on)"/>
      <node name="m" pkg="p" type="t"><param name="x" value="1" if="$(arg on)"/></node>""",
    )
    plan = load_launch(path)
    assert sorted(plan.params) == ["/a", "/m/x"] and [n.name for n in plan.nodes] == ["m"]
    plan = load_launch(path, {"on": "false"})
    assert sorted(plan.params) == ["/b", "/c"] and [n.name for n in plan.nodes] == ["n", "m"]
    with pytest.raises(LaunchError, match='if="maybe" is not a boolean'):
        load_launch(path, {"on": "maybe"})


def test_params_types_textfile_and_private_names(tmp_path):
    (tmp_path / "notes.txt").write_text("hello\n")
    path = write(
        tmp_path,
        "params.launch",
        f"""
      <param name="i" value="3"/>
      <param name="s" value="3" type="str"/>
      <param name="d" value="3" type="double"/>
      <param name="y" type="yaml" value="{{a: [1, 2]}}"/>
      <param name="/global/t" textfile="{tmp_path}/notes.txt"/>
      <group ns="g">
        <param name="~private_for_all" value="7"/>
        <node name="n" pkg="p" type="t"><param name="rel" value="1"/><param name="~tilde" value="2"/>
          <param name="/abs" value="3"/></node>
      </group>""",
    )
    plan = load_launch(path)
    assert plan.params["/i"] == 3 and plan.params["/s"] == "3" and plan.params["/d"] == 3.0
    assert plan.param("/y") == {"a": [1, 2]} and plan.params["/global/t"] == "hello\n"
    assert plan.params["/g/n/rel"] == 1 and plan.params["/g/n/tilde"] == 2 and plan.params["/abs"] == 3
    assert plan.params["/g/n/private_for_all"] == 7
    assert plan.nodes[0].private("tilde") == "/g/n/tilde"


def test_param_command_runs_xacro_in_process(tmp_path):
    path = write(
        tmp_path,
        "xacro.launch",
        """
      <param name="robot_description"
             command="$(find xacro)/xacro --inorder '$(find racecar_description)/urdf/racecar.xacro'"/>
      <param name="old_style" command="$(find xacro)/xacro.py $(find racecar_description)/urdf/racecar.xacro"/>""",
    )
    plan = load_launch(path)
    robot = parse_urdf(plan.params["/robot_description"])
    assert robot.joints["left_steering_hinge_joint"].type == "revolute"
    assert plan.params["/old_style"] == plan.params["/robot_description"] == expand_xacro()
    shell = write(tmp_path, "shell.launch", '<param name="x" command="cat /etc/hostname"/>')
    with pytest.raises(LaunchError, match=r"shell.launch:3: <param name=\"x\">: command 'cat' is not run by the sim"):
        load_launch(shell)


def test_param_command_passes_xacro_args(tmp_path):
    (tmp_path / "box.xacro").write_text("""<?xml version="1.0"?>
<robot name="box" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:arg name="size" default="1"/>
  <link name="base"><visual><geometry><box size="$(arg size) 1 1"/></geometry></visual></link>
</robot>""")
    path = write(tmp_path, "args.launch", f'<param name="d" command="xacro {tmp_path}/box.xacro size:=0.25"/>')
    assert 'size="0.25 1 1"' in load_launch(path).params["/d"]


def test_rosparam_load_file_and_inline_with_ns(tmp_path):
    (tmp_path / "gains.yaml").write_text("racecar:\n  ctrl:\n    type: T\n    pid: {p: 1.0, d: 0.5}\n")
    path = write(
        tmp_path,
        "rosparam.launch",
        f"""
      <rosparam file="{tmp_path}/gains.yaml" command="load"/>
      <rosparam file="{tmp_path}/gains.yaml" command="load" ns="car2"/>
      <group ns="car3"><rosparam file="{tmp_path}/gains.yaml" command="load" ns="sub"/></group>
      <rosparam param="list">[1, 2, 3]</rosparam>
      <rosparam ns="inline">
        a: 1
        b: {{c: two}}
      </rosparam>
      <rosparam command="delete" param="car2/racecar/ctrl/pid"/>
      <node name="n" pkg="p" type="t"><rosparam>gain: 4</rosparam></node>""",
    )
    plan = load_launch(path)
    assert plan.param("/racecar/ctrl") == {"type": "T", "pid": {"p": 1.0, "d": 0.5}}
    assert plan.param("/car2/racecar/ctrl") == {"type": "T"}
    assert plan.param("/car3/sub/racecar/ctrl/pid/d") == 0.5
    assert plan.params["/list"] == [1, 2, 3] and plan.param("/inline") == {"a": 1, "b": {"c": "two"}}
    assert plan.params["/n/gain"] == 4
    assert plan.sources["/racecar/ctrl/type"] == tmp_path / "gains.yaml"


def test_remaps_launch_scoped_and_node_scoped_and_env(tmp_path):
    path = write(
        tmp_path,
        "remap.launch",
        """
      <remap from="/scan" to="/front/scan"/>
      <env name="A" value="1"/>
      <group ns="car1">
        <remap from="odom" to="vesc/odom"/>
        <node name="n" pkg="p" type="t" args="--flag 'two words'">
          <remap from="cmd" to="~private_cmd"/>
          <remap from="/scan" to="laser"/>
          <env name="B" value="2"/>
        </node>
      </group>
      <node name="m" pkg="p" type="t"/>""",
    )
    n, m = load_launch(path).nodes
    assert n.args == ("--flag", "two words") and n.env == (("A", "1"), ("B", "2"))
    assert n.resolve("odom") == "/car1/vesc/odom"  # the group's remap, resolved in the node's namespace
    assert n.resolve("cmd") == "/car1/n/private_cmd"
    assert n.resolve("/scan") == "/car1/laser"  # the node's own remap wins over the launch-scoped one
    assert n.resolve("other") == "/car1/other" and n.resolve("~x") == "/car1/n/x"
    assert m.resolve("/scan") == "/front/scan" and m.resolve("odom") == "/odom" and m.env == (("A", "1"),)
