"""The writer process's CPU in the main job: what `racecar-sim run` hands its writer process, replayed without the
simulation, so that the figure is the writer's alone (no physics, no drawing to share the cores with).

    python bench/bench_writer.py [--duration 20] [--rounds 3] [--compare OLD/src] [--quick]

A run records the hand-overs once (`racecar-sim run --raw-images --no-video --no-summary`, walker, wall-follow):
every message with its log time, and the camera's raw frames. Each round then replays them, in a fresh process
per side, through a WriterProcess that writes what the main job writes (run.mcap with the camera as JPEG
CompressedImage, camera.mp4), and reads the writer process's CPU seconds (user + system) from the OS. `--compare
SRC` replays with PYTHONPATH=SRC too, interleaved; SRC needs the writer process's hand-over operations (issue 34's
second round on). Printed: the medians, and new/old.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from machine_info import machine_line


def record(duration: float, out: Path) -> Path:
    """The hand-overs to replay: a main job's run.mcap with raw camera images."""
    cmd = [sys.executable, "-m", "racecar_sim", "run", "--duration", f"{duration:g}", "--out", str(out)]
    cmd += ["--raw-images", "--no-video", "--no-summary"]
    result = subprocess.run(cmd, check=False, capture_output=True, text=True, timeout=1800)
    if result.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed ({result.returncode}):\n{result.stderr[-2000:]}")
    return out / "run.mcap"


def replay(source: Path, out: Path) -> None:
    """Hand `source`'s messages to a writer process as a run does (images as JPEG and video frames); print its CPU."""
    from mcap.reader import make_reader

    from racecar_sim.msgs import deserialize
    from racecar_sim.recording.images import JPEG_QUALITY, compressed_topic
    from racecar_sim.recording.recording_file import open_recording_file
    from racecar_sim.recording.run_recording import COMPRESSED_MSGTYPE
    from racecar_sim.recording.writer_process import JPEG, OPEN_MCAP, ProcessVideo, WriterProcess

    with open(source, "rb") as stream:
        messages = [(c.topic, s.name, m.data, m.log_time) for s, c, m in make_reader(stream).iter_messages()]
    out.mkdir(parents=True, exist_ok=True)
    mcap = open_recording_file(out / "run.mcap")
    start = time.perf_counter()
    process = WriterProcess("bench", pass_fds=[mcap.fileno()])
    process.send((OPEN_MCAP, mcap.fileno(), str(out / "run.mcap"), "zstd"))
    mcap.close()
    video = None
    frames = 0
    for topic, msgtype, data, log_time in messages:
        if msgtype != "sensor_msgs/msg/Image":
            process.message(topic, msgtype, data, log_time)
            continue
        image = deserialize(data, msgtype)
        if video is None:
            video = ProcessVideo(process, out / "camera.mp4", 30.0, image.width, image.height)
        process.send((JPEG, compressed_topic(topic), COMPRESSED_MSGTYPE, process.image(image), log_time, JPEG_QUALITY))
        video.write_image(image)
        frames += 1
    if video is not None:
        video.close()
    process.close()
    used = resource.getrusage(resource.RUSAGE_CHILDREN)
    print(f"cpu {used.ru_utime + used.ru_stime:.3f} wall {time.perf_counter() - start:.3f} frames {frames}")


def run_side(source: Path, pythonpath: str | None, out: Path) -> tuple[float, float, int]:
    """One replay in a fresh process: the writer process's CPU seconds, the replay's wall seconds, the frames."""
    env = dict(os.environ)
    if pythonpath is not None:
        env["PYTHONPATH"] = pythonpath
    cmd = [sys.executable, __file__, "--replay", str(source), str(out)]
    result = subprocess.run(cmd, check=False, capture_output=True, text=True, env=env, timeout=1800)
    if result.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed ({result.returncode}):\n{result.stderr[-2000:]}")
    fields = result.stdout.split()
    cpu, wall, frames = (fields[fields.index(name) + 1] for name in ("cpu", "wall", "frames"))
    return float(cpu), float(wall), int(frames)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--duration", type=float, default=20.0, help="sim seconds of the recorded run (default 20)")
    p.add_argument("--rounds", type=int, default=3, help="interleaved rounds; medians are printed (default 3)")
    p.add_argument("--compare", metavar="SRC", help="also replay with PYTHONPATH=SRC (the code before)")
    p.add_argument("--quick", action="store_true", help="1 sim s, 1 round (a check that the bench runs)")
    p.add_argument("--replay", nargs=2, metavar=("SOURCE", "OUT"), help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.replay:
        replay(Path(args.replay[0]), Path(args.replay[1]))
        return
    if args.quick:
        args.duration, args.rounds = 1.0, 1
    print(machine_line())
    sides = {"new": None} if args.compare is None else {"new": None, "old": args.compare}
    cpu: dict[str, list[float]] = {side: [] for side in sides}
    with tempfile.TemporaryDirectory() as work:
        source = record(args.duration, Path(work) / "source")
        for n in range(args.rounds):
            for side, pythonpath in sides.items():
                used, wall, frames = run_side(source, pythonpath, Path(work) / f"{side}{n}")
                cpu[side].append(used)
                print(
                    f"round {n + 1}/{args.rounds}: {side} writer process {used:.2f} s CPU ({wall:.2f} s wall, "
                    f"{frames} frames)"
                )
    print(f"the writer process's CPU for {args.duration:g} sim s of the main job, median of {args.rounds} rounds")
    for side, values in cpu.items():
        median = statistics.median(values)
        print(f"{side:4s} {median:.2f} s, {1000 * median / args.duration:.0f} ms a sim second")
    if "old" in cpu:
        print(f"new/old {statistics.median(cpu['new']) / statistics.median(cpu['old']):.3f}")


if __name__ == "__main__":
    main()
