"""Start-up: what importing racecar-sim loads and changes, each checked in a fresh interpreter.

`import racecar_sim.msgs` must not load MuJoCo or the mesh libraries, `import racecar_sim` must not touch the
OpenGL environment, the CLI imports only the subcommand it runs, and a MUJOCO_GL backend whose library is missing
still breaks neither the simulator nor the CLI (the guard now runs on first use, not on import). No timings here:
bench/bench_startup.py measures them.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import pytest

HEAVY = ("mujoco", "trimesh", "scipy", "matplotlib", "OpenGL", "glfw")
GL_VARIABLES = ("MUJOCO_GL", "PYOPENGL_PLATFORM")

# libOSMesa made unloadable inside the child, as on a machine without libosmesa6: PyOpenGL then fails with the
# AttributeError that `import mujoco` does not catch when MUJOCO_GL=osmesa
NO_OSMESA = textwrap.dedent("""
    import ctypes, ctypes.util
    _init, _find = ctypes.CDLL.__init__, ctypes.util.find_library
    def _no_osmesa(self, name, *args, **kwargs):
        if name and "OSMesa" in str(name):
            raise OSError(f"{name}: cannot open shared object file: No such file or directory")
        _init(self, name, *args, **kwargs)
    ctypes.CDLL.__init__ = _no_osmesa
    ctypes.util.find_library = lambda name: None if "OSMesa" in name else _find(name)
""")


def _child(code: str, env: dict[str, str] | None = None, prelude: str = "") -> subprocess.CompletedProcess:
    """`code` (after `prelude`) in a fresh interpreter whose GL variables come only from `env`."""
    parent = {k: v for k, v in os.environ.items() if k not in GL_VARIABLES}
    return subprocess.run(
        [sys.executable, "-c", prelude + textwrap.dedent(code)],
        capture_output=True,
        text=True,
        timeout=120,
        env={**parent, **(env or {})},
        check=False,
    )


def _json(code: str, env: dict[str, str] | None = None, prelude: str = "") -> dict:
    result = _child(code, env, prelude)
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout.strip().splitlines()[-1])


def _loaded(statement: str) -> list[str]:
    return _json(f"""
        import json, sys
        {statement}
        print(json.dumps({{"loaded": [m for m in {HEAVY!r} if m in sys.modules]}}))
    """)["loaded"]


def test_msgs_load_no_mujoco_and_no_mesh_libraries():
    assert _loaded("import racecar_sim.msgs") == []


def test_core_and_the_package_load_nothing_heavy():
    assert _loaded("import racecar_sim, racecar_sim.core.errors, racecar_sim.core.time") == []


@pytest.mark.parametrize(
    "env",
    [{}, {"MUJOCO_GL": "egl"}, {"MUJOCO_GL": "osmesa"}, {"MUJOCO_GL": "egl", "PYOPENGL_PLATFORM": "egl"}],
    ids=["unset", "egl", "osmesa", "egl+pyopengl"],
)
def test_import_leaves_the_gl_environment_and_mujoco_alone(env):
    out = _json(
        f"""
        import json, os, sys
        before = {{k: os.environ.get(k) for k in {GL_VARIABLES!r}}}
        import racecar_sim
        after = {{k: os.environ.get(k) for k in {GL_VARIABLES!r}}}
        print(json.dumps({{"before": before, "after": after, "mujoco": "mujoco" in sys.modules}}))
    """,
        env,
    )
    assert out["after"] == out["before"] == {k: env.get(k) for k in GL_VARIABLES}
    assert not out["mujoco"]


def test_the_package_names_resolve_on_first_use():
    out = _json("""
        import json, sys
        import racecar_sim
        from racecar_sim import Car, Simulator, Spawn
        import racecar_sim.runtime, racecar_sim.worlds
        try:
            racecar_sim.NoSuchThing
        except AttributeError as exc:
            missing = str(exc)
        print(json.dumps({"same": [Simulator is racecar_sim.runtime.Simulator, Car is racecar_sim.runtime.Car,
                                   Spawn is racecar_sim.worlds.Spawn],
                          "all": sorted(racecar_sim.__all__), "dir": all(n in dir(racecar_sim) for n in
                                                                      racecar_sim.__all__),
                          "missing": missing}))
    """)
    assert out["same"] == [True, True, True]
    assert out["all"] == ["Car", "Simulator", "Spawn", "__version__"] and out["dir"]
    assert "NoSuchThing" in out["missing"]


def test_the_cli_imports_only_the_subcommand_it_runs():
    out = _json(
        """
        import contextlib, io, json, os, sys
        from racecar_sim.cli.main import main
        with contextlib.redirect_stdout(io.StringIO()):
            code = main(["worlds"])
        print(json.dumps({"code": code, "cli": sorted(m for m in sys.modules if m.startswith("racecar_sim.cli.")),
                          "gl": [m for m in ("OpenGL", "glfw", "matplotlib") if m in sys.modules],
                          "MUJOCO_GL": os.environ.get("MUJOCO_GL")}))
    """,
        {"MUJOCO_GL": "egl"},
    )
    assert out["code"] == 0
    others = {
        "racecar_sim.cli.run",
        "racecar_sim.cli.sweep",
        "racecar_sim.cli.launch",
        "racecar_sim.cli.bench",
        "racecar_sim.cli.teleop",
        "racecar_sim.cli.describe",
        "racecar_sim.cli.recover",
    }
    assert "racecar_sim.cli.worlds" in out["cli"] and not others & set(out["cli"]), out["cli"]
    assert out["gl"] == [] and out["MUJOCO_GL"] == "egl"


def test_the_cli_help_still_lists_every_subcommand():
    result = _child("from racecar_sim.cli.main import main\nmain(['--help'])\n")
    for name in ("run", "teleop", "launch", "describe", "bench", "worlds", "recover", "ros-env", "sweep"):
        assert f"    {name} " in result.stdout, result.stdout


def test_a_missing_osmesa_breaks_mujoco_but_not_the_simulator():
    """The MUJOCO_GL guard, moved off import, still protects each first use of MuJoCo."""
    env = {"MUJOCO_GL": "osmesa"}
    bare = _child("import mujoco\n", env, NO_OSMESA)
    assert bare.returncode != 0 and "AttributeError" in bare.stderr  # what the guard is there for
    out = _json(
        """
        import json, os
        import racecar_sim
        from racecar_sim import Simulator
        from racecar_sim.core.errors import RenderingError
        from racecar_sim.render.gl import create_context
        sim = Simulator(world="empty", camera=False, sensor_noise=False)
        sim.run_until(0.05)
        try:
            create_context()
        except RenderingError as exc:
            error = str(exc)
        print(json.dumps({"time": sim.time, "error": error, "MUJOCO_GL": os.environ.get("MUJOCO_GL")}))
    """,
        env,
        NO_OSMESA,
    )
    assert out["time"] == pytest.approx(0.05) and out["MUJOCO_GL"] == "osmesa"
    assert "libosmesa6" in out["error"] and "--no-camera" in out["error"]


def test_a_missing_osmesa_gives_the_camera_error_not_a_traceback():
    out = _json(
        """
        import json
        from racecar_sim.core.errors import RenderingError
        from racecar_sim.render.gl import create_context
        try:
            create_context()
        except RenderingError as exc:
            print(json.dumps({"error": str(exc)}))
    """,
        {"MUJOCO_GL": "osmesa"},
        NO_OSMESA,
    )
    assert len(out["error"].splitlines()) == 1 and "libosmesa6" in out["error"], out


def test_a_missing_osmesa_does_not_stop_a_cli_run_without_camera(tmp_path):
    result = _child(
        f"""
        import sys
        from racecar_sim.cli.main import main
        sys.exit(main(["run", "--no-camera", "--world", "empty", "--duration", "0.2", "--out", {str(tmp_path)!r},
                       "--no-summary", "--no-record"]))
    """,
        {"MUJOCO_GL": "osmesa"},
        NO_OSMESA,
    )
    assert result.returncode == 0, result.stderr
    assert "sim time         0.20 s" in result.stdout


def test_an_empty_world_loads_no_mesh_library(tmp_path):
    """A world and car without mesh files build and step without trimesh (and its scipy, networkx): up to the
    first scan (0.025 s) nothing but mujoco; the whole run none of trimesh, matplotlib, GLFW or PyOpenGL (a
    scan that sees something - the floor, as the car settles - loads numba for the wall-follow fit, and numba
    looks at scipy's version)."""
    runs = {
        duration: _loaded(f"""
        import contextlib, io
        from racecar_sim.cli.main import main
        with contextlib.redirect_stdout(io.StringIO()):
            assert main(["run", "--no-camera", "--world", "empty", "--duration", "{duration}", "--out",
                         {str(tmp_path)!r}, "--no-summary", "--overwrite"]) == 0
    """)
        for duration in ("0.02", "0.1")
    }
    assert runs["0.02"] == ["mujoco"]
    assert set(runs["0.1"]) <= {"mujoco", "scipy"}


def test_a_recorded_run_leaves_the_mcap_writer_to_its_writer_process(tmp_path):
    """The simulation process opens the file and hands what it publishes to its writer process: it loads neither
    mcap nor lz4 (~12 ms of its start), and the file its child writes holds /clock at gazebo_ros's 100 Hz."""
    from mcap.reader import make_reader

    out = _json(f"""
        import contextlib, io, json, sys
        from racecar_sim.cli.main import main
        with contextlib.redirect_stdout(io.StringIO()):
            code = main(["run", "--no-camera", "--world", "empty", "--duration", "0.5", "--out", {str(tmp_path)!r},
                         "--no-summary", "--no-video"])
        print(json.dumps({{"code": code, "loaded": [m for m in ("mcap", "lz4", "racecar_sim.recording.mcap_recorder")
                                                   if m in sys.modules]}}))
    """)
    assert out == {"code": 0, "loaded": []}
    with open(tmp_path / "run.mcap", "rb") as stream:
        stamps = [message.log_time for _, _, message in make_reader(stream).iter_messages(topics=["/clock"])]
    assert stamps == [10_000_000 * k for k in range(1, 51)]


@pytest.mark.parametrize("argv", [["run", "--help"], ["worlds"]], ids=["run --help", "worlds"])
def test_run_help_and_worlds_load_neither_numba_nor_matplotlib(argv):
    """Commands that only print stay clear of the compiler and the plotting library (each ~0.3 s to import)."""
    out = _json(f"""
        import contextlib, io, json, sys
        from racecar_sim.cli.main import main
        text = io.StringIO()
        with contextlib.redirect_stdout(text):
            try:
                code = main({argv!r})
            except SystemExit as exc:  # --help exits through argparse
                code = exc.code
        print(json.dumps({{"code": code, "printed": text.getvalue(),
                          "loaded": [m for m in ("numba", "matplotlib", "llvmlite") if m in sys.modules]}}))
    """)
    assert out["code"] == 0
    assert ("--duration" in out["printed"]) if argv[0] == "run" else ("walker" in out["printed"])
    assert out["loaded"] == [], out["loaded"]


def test_the_ros_help_texts_name_the_bridges_own_address():
    """cli/ros_env.py repeats the ROS 1 bridge's loopback address and master port for its help texts, so that a run
    without --ros imports none of the bridge."""
    from racecar_sim.bridges.ros1 import environment, master
    from racecar_sim.cli import ros_env

    assert (ros_env.LOOPBACK, ros_env.DEFAULT_PORT) == (environment.LOOPBACK, master.DEFAULT_PORT)


COLLECTOR_PROBE = """
import gc, json, sys
from racecar_sim.nodes import NodeBase


class Probe(NodeBase):
    def __init__(self, ctx) -> None:
        self.seen = None
        ctx.timers.every(20.0, self.tick, "probe")
        self.out = sys.argv[sys.argv.index("--out") + 1] + ".probe.json"

    def tick(self, now_ns: int) -> None:
        if self.seen is None:
            self.seen = {"enabled": gc.isenabled(), "frozen": gc.get_freeze_count()}
            with open(self.out, "w") as f:
                json.dump(self.seen, f)
"""


def test_a_cli_run_has_the_collector_on_in_its_loop(tmp_path):
    """The `racecar-sim` process holds the cyclic collector off while it imports and builds (cli/collector.py), and a
    run turns it back on before its loop, with what the build made frozen: garbage the run makes is collected."""
    (tmp_path / "probe.py").write_text(COLLECTOR_PROBE)
    out = tmp_path / "run"
    result = subprocess.run(
        [sys.executable, "-m", "racecar_sim", "run", "--world", "empty", "--no-camera", "--no-record", "--no-video",
         "--no-summary", "--driver", f"{tmp_path / 'probe.py'}:Probe", "--duration", "0.1", "--out", str(out)],
        capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    seen = json.loads((tmp_path / "run.probe.json").read_text())
    assert seen["enabled"] is True
    assert seen["frozen"] > 10_000  # the imports' and the build's objects, out of the collector's way
