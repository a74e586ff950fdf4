"""`racecar-sim worlds`: list the built-in worlds, or draw one from above to a PNG (--show)."""

from __future__ import annotations

import argparse
from pathlib import Path

from racecar_sim.cli.args import add_world_arguments, apply_ros_path_options
from racecar_sim.cli.spawns import check_spawn_option
from racecar_sim.core.errors import RacecarSimError
from racecar_sim.worlds import BUILTIN_WORLDS, load_world, world_names, world_summary


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("worlds", help="list the built-in worlds, or draw one from above to a PNG (--show)")
    p.add_argument("--show", metavar="NAME|PATH", help="draw this world (built-in name or world file) to a PNG")
    p.add_argument("--names", action="store_true", help="only the built-in worlds' names, one a line (for scripts)")
    p.add_argument("--out", metavar="FILE.png", help="PNG to write (default: runs/<world name or file stem>.png)")
    add_world_arguments(p, world_option=False)


def listing() -> str:
    """One line per built-in world: name, spawn pose x,y,yaw and summary (read from worlds.yaml only)."""
    names = world_names()
    width = max(map(len, names), default=0)
    lines = []
    for name in names:
        x, y, _, yaw = BUILTIN_WORLDS[name].get("spawn", (0.0, 0.0, 0.0, 0.0))
        spawn = f"spawn {x:g},{y:g},{yaw:g}"
        lines.append(f"{name:<{width}}  {spawn:<18} {world_summary(name)}")
    return "\n".join(lines)


def main(args: argparse.Namespace) -> int:
    if args.names:
        print("\n".join(world_names()))
        return 0
    if args.show is None:
        print(listing())
        return 0
    apply_ros_path_options(args)  # a --model-path that is not a folder is refused
    world = load_world(args.show, spawn=args.spawn, model_path=args.model_path, wall_height=args.wall_height)
    check_spawn_option(world, args)  # as `run` checks it: in an obstacle, below the ground, over nothing
    name = args.show if args.show in BUILTIN_WORLDS else Path(args.show).stem
    out = Path(args.out) if args.out else Path("runs") / f"{name}.png"  # runs/ is what .gitignore keeps out
    from racecar_sim.plots import save_world_png  # matplotlib only loads when a map is drawn

    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        save_world_png(world, out)
    except OSError as exc:
        raise RacecarSimError(f"{out}: cannot write the map ({exc.strerror or exc})") from None
    print(out.absolute())  # the file written, wherever the command ran
    return 0
