"""Expanded xacro files kept on disk, so that a run does not expand (nor import) xacro every time it starts.

Expanding the shipped car takes ~0.1 s of a 0.5 s start, and importing xacro and its YAML ~0.03 s more. An entry is
the URDF text with what it was made from: the file, the `xacro:arg` mappings, ROS_PACKAGE_PATH, the xacro install,
every file read (its whole content: a few kB, compared byte for byte), every `$(find pkg)` answered and every
variable `$(env NAME)` / `$(optenv NAME)` reads (the shipped car's DISABLE_GAZEBO_LASER and DISABLE_GAZEBO_CAMERA).
It is used only while all of these are the same; a file whose variable names are not plain words is never kept, nor
a failed expansion. The entries live in ~/.cache/racecar-sim/xacro/ (or under $XDG_CACHE_HOME);
RACECAR_SIM_XACRO_CACHE=0 turns the cache off, and a cache that cannot be written is simply not kept.
"""

from __future__ import annotations

import importlib.util
import json
import os
import re
import zlib
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path

FORMAT = 1  # bump when what an entry holds, or how the text is made from xacro's document, changes
ENV_READ = re.compile(rb"\$\((?:env|optenv)\s")
ENV_NAME = re.compile(rb"\$\((?:env|optenv)\s+([A-Za-z_][A-Za-z0-9_]*)[\s)]")
OFF_VARIABLE = "RACECAR_SIM_XACRO_CACHE"

Finds = list[tuple[str, str, str]]  # (package, the file that asked, the folder it resolved to)


def cache_dir() -> Path:
    """Where the entries live."""
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "racecar-sim" / "xacro"


def enabled() -> bool:
    return os.environ.get(OFF_VARIABLE, "1") != "0"


def _xacro_install() -> list[object]:
    """Which xacro would expand: its file, size and time (importlib.metadata's version costs ~15 ms to ask)."""
    spec = importlib.util.find_spec("xacro")
    if spec is None or spec.origin is None:
        return []
    stat = os.stat(spec.origin)
    return [spec.origin, stat.st_size, stat.st_mtime_ns]


def _what(path: Path, mappings: Mapping[str, str]) -> list[object]:
    """Everything but the files' contents that the text depends on (an entry holds it whole: no false hit)."""
    env = os.environ.get("ROS_PACKAGE_PATH", "")
    given = [str(path), str(path.resolve())]  # xacro's banner names the file as given
    return json.loads(json.dumps([FORMAT, *given, sorted(mappings.items()), env, _xacro_install()]))


def _entry(what: list[object]) -> Path:
    return cache_dir() / f"{zlib.crc32(json.dumps(what).encode()):08x}.json"


def _content(path: str) -> str | None:
    try:
        return Path(path).read_bytes().decode("latin-1")  # bytes as text, one for one, for JSON
    except OSError:
        return None


def lookup(path: Path, mappings: Mapping[str, str], find: Callable[[str, str], str]) -> str | None:
    """The kept URDF text of `path` expanded with `mappings`, or None when there is none or it is out of date.
    `find(package, asker)` answers `$(find package)` as the expansion would now."""
    if not enabled():
        return None
    what = _what(path, mappings)
    try:
        entry = json.loads(_entry(what).read_text())
        files, finds, env, text = entry["files"], entry["finds"], entry["env"], entry["text"]
    except (OSError, ValueError, KeyError, TypeError):
        return None
    if entry.get("what") != what or any(os.environ.get(name) != value for name, value in env.items()):
        return None
    if any(_content(name) != content for name, content in files):
        return None
    try:
        if any(find(package, asker) != folder for package, asker, folder in finds):
            return None
    except Exception:  # a package gone since: expand again, and let the expansion say what is missing
        return None
    return text if isinstance(text, str) else None


def store(path: Path, mappings: Mapping[str, str], text: str, read: Iterable[str], finds: Finds) -> None:
    """Keep `text`, made from the files `read` (`path` among them) and the `$(find)` answers `finds`."""
    if not enabled():
        return
    files, env = [], {}
    for name in dict.fromkeys(os.path.abspath(name) for name in [str(path), *read]):
        try:
            data = Path(name).read_bytes()
        except OSError:
            return
        names = ENV_NAME.findall(data)
        if len(names) != len(ENV_READ.findall(data)):
            return  # a variable named by a substitution: what the text depends on is not known here
        env.update({v.decode(): os.environ.get(v.decode()) for v in names})
        files.append((name, data.decode("latin-1")))
    import tempfile

    what = _what(path, mappings)
    target = _entry(what)
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile("w", dir=target.parent, suffix=".tmp", delete=False) as f:
            json.dump({"what": what, "files": files, "finds": finds, "env": env, "text": text}, f)
    except OSError:
        return
    try:
        os.replace(f.name, target)  # whole or not at all, for a run started beside this one
    except OSError:
        Path(f.name).unlink(missing_ok=True)
