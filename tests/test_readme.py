"""The Python examples of the docs run as written: the Python API and Your own driver (docs/drivers.md), the
Gymnasium example (docs/learning.md). (They were the README's until issue 35 moved them to docs/.)"""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DRIVERS = ROOT / "docs" / "drivers.md"
LEARNING = ROOT / "docs" / "learning.md"


def test_readme_python_example_runs(tmp_path, monkeypatch, capsys):
    code = re.search(r"## Python API\s+(?:<!--.*?-->\s+)?```python\n(.*?)```", DRIVERS.read_text(), re.S).group(1)
    monkeypatch.chdir(tmp_path)
    (tmp_path / "runs").mkdir()
    exec(compile(code, str(DRIVERS), "exec"), {})
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 100  # /vesc/odom at 20 Hz for 5 s
    assert lines[-1].split()[0] == "5" and float(lines[1].split()[1]) > 0.0  # t = 5 s; it moved forward
    assert (tmp_path / "runs" / "api.mcap").stat().st_size > 10_000


def test_readme_driver_example_is_the_shipped_example():
    code = re.search(r"## Your own driver.*?```python\n(.*?)```", DRIVERS.read_text(), re.S).group(1)
    assert code == (ROOT / "examples" / "follow_the_gap.py").read_text()


def test_readme_driver_example_laps_the_racecourse(capsys):
    code = re.search(r"## Your own driver.*?```python\n(.*?)```", DRIVERS.read_text(), re.S).group(1)
    exec(compile(code, str(DRIVERS), "exec"), {"__name__": "__main__"})  # as `python examples/follow_the_gap.py`
    rows = [[float(v) for v in line.split()] for line in capsys.readouterr().out.splitlines()]
    assert len(rows) == 1200 and rows[-1][0] == 60.0  # /vesc/odom at 20 Hz for 60 s
    xy = [(x, y) for _, x, y in rows]
    # round the course (its far corner is ~20 m from the start) and back near the start line
    assert max(abs(x) for x, _ in xy) > 15.0 and min(y for _, y in xy) < -8.0 and max(y for _, y in xy) > 10.0


def test_readme_gymnasium_example_runs():
    code = re.search(r"## Learning.*?```python\n(.*?)```", LEARNING.read_text(), re.S).group(1)
    scope: dict = {"__name__": "readme_envs"}
    exec(compile(code, str(LEARNING), "exec"), scope)
    assert scope["obs"]["scan"].shape == (1081,) and scope["reward"] == scope["reward"]  # a number, not NaN
    assert scope["observations"]["scan"].shape == (4, 1081)  # 4 async envs, one scan each
    scope["env"].close()
