"""`racecar-sim run`'s process ends without the interpreter's teardown only where nothing depends on it
(cli/fast_exit.py): the atexit handlers still run, the output and the exit code are the command's; a user's code, a
thread Python would wait for, a tracer or a profiler keep the exit as it always was.

Whether the teardown ran is read from `python -v`, which reports it ("# cleanup ...", "# destroy ...")."""

from __future__ import annotations

import os
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from racecar_sim.cli import fast_exit

# the command as its console script runs it, with an atexit handler of its own
WRAPPER = """
import atexit, os, sys
atexit.register(lambda: os.write(2, b"ATEXIT\\n"))
from racecar_sim.cli.main import entry
sys.argv = ["racecar-sim", *sys.argv[1:]]
sys.exit(entry())
"""
QUIET = ["--no-camera", "--no-record", "--no-video", "--no-summary"]
TEARDOWN = "# cleanup["  # what `python -v` prints as the interpreter tears its modules down

# a user's driver: a node that counts its scans in a file
COUNTER = """
from racecar_sim.nodes import NodeBase

class Counter(NodeBase):
    def __init__(self, ctx):
        self.path = f"scans-{ctx.names.namespace or 'racecar'}.txt"
        self.count = 0
        ctx.bus.subscribe(ctx.topic("/scan"), self.scan)

    def scan(self, msg):
        self.count += 1
        with open(self.path, "w") as f:
            f.write(str(self.count))
"""


def _run(tmp_path: Path, *args: str, wrapper: str = WRAPPER) -> subprocess.CompletedProcess[str]:
    src = str(Path(__file__).parents[1] / "src")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONUNBUFFERED"}  # C's stdio buffered, as users have it
    env["PYTHONPATH"] = os.pathsep.join([src, os.environ.get("PYTHONPATH", "")])
    return subprocess.run(
        [sys.executable, "-v", "-c", wrapper, "run", *args],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        env=env,
        timeout=120,
    )


def test_a_run_of_the_products_own_code_ends_without_the_teardown_keeping_output_and_handlers(tmp_path: Path):
    done = _run(tmp_path, "--world", "empty", "--cars", "2", *QUIET, "--duration", "0.5", "--out", "run")
    assert done.returncode == 0, done.stderr[-2000:]
    assert "real-time factor" in done.stdout
    assert done.stdout.splitlines()[-1].startswith("car2 final pose")  # the summary to its last line
    assert "ATEXIT" in done.stderr
    assert TEARDOWN not in done.stderr


def test_a_program_that_calls_main_goes_on_after_it(tmp_path: Path):
    """Only the command's entry point ends the process: a program of the user's that sets sys.argv and calls main()
    (an API older than the fast exit) gets the exit code back and runs on."""
    program = WRAPPER.replace("import entry", "import main").replace(
        "sys.exit(entry())", "code = main()\nprint('AFTER MAIN', code)\nsys.exit(code)"
    )
    done = _run(tmp_path, "--world", "empty", *QUIET, "--duration", "0.1", "--out", "run", wrapper=program)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.splitlines()[-1] == "AFTER MAIN 0"
    assert "ATEXIT" in done.stderr


def test_an_errors_exit_code_and_message_are_kept(tmp_path: Path):
    done = _run(tmp_path, "--world", "nowhere_world", *QUIET, "--duration", "0.1", "--out", "run")
    assert done.returncode == 2
    assert "racecar-sim: error:" in done.stderr and "nowhere_world" in done.stderr
    assert "ATEXIT" in done.stderr and TEARDOWN not in done.stderr


@pytest.mark.parametrize("cars", [[], ["--cars", "2"]])
def test_a_users_driver_file_keeps_the_teardown(tmp_path: Path, cars: list[str]):
    (tmp_path / "counter.py").write_text(COUNTER)
    done = _run(tmp_path, "--world", "empty", *cars, "--driver", "counter.py:Counter", *QUIET, "--duration", "1")
    assert done.returncode == 0, done.stderr[-2000:]
    assert "ATEXIT" in done.stderr and TEARDOWN in done.stderr
    counts = {p.name: p.read_text() for p in tmp_path.glob("scans-*.txt")}
    assert counts == ({"scans-car1.txt": "40", "scans-car2.txt": "40"} if cars else {"scans-racecar.txt": "40"})


def test_a_thread_python_would_wait_for_or_a_profiler_keep_the_teardown():
    assert not fast_exit._waited_for()
    release = threading.Event()
    worker = threading.Thread(target=release.wait)
    worker.start()
    try:
        assert fast_exit._waited_for()
    finally:
        release.set()
        worker.join()
    assert not fast_exit._waited_for()
    sys.setprofile(lambda *args: None)
    try:
        assert fast_exit._waited_for()
    finally:
        sys.setprofile(None)
    daemon = threading.Thread(target=release.wait, daemon=True)  # Python's exit does not wait for a daemon
    daemon.start()
    assert not fast_exit._waited_for()


def test_what_c_code_left_in_its_stdio_buffer_is_written(tmp_path: Path):
    """exit() flushes C's stdio buffers and os._exit does not: what C code printed at the end (to a pipe: fully
    buffered, so still in the buffer) arrives all the same."""
    c_print = "import ctypes\natexit.register(lambda: ctypes.CDLL(None).printf(b'C-LEVEL\\n'))\nfrom racecar_sim"
    wrapper = WRAPPER.replace("from racecar_sim", c_print, 1)
    done = _run(tmp_path, "--world", "empty", *QUIET, "--duration", "0.1", "--out", "run", wrapper=wrapper)
    assert done.returncode == 0, done.stderr[-2000:]
    assert TEARDOWN not in done.stderr
    assert done.stdout.endswith("C-LEVEL\n")
