"""The run folder that `run`, `teleop`, `launch` and `play` all leave, made by one piece of code.

    run.mcap      every topic (camera images as JPEG CompressedImage unless --raw-images), by a writer process
    summary.png   the world from above: each car's path, crashes and lap ends marked, the last scan and camera frame
    summary.json  per car: distance, mean speed, laps and lap times, best lap, crashes with their sim times and what
                  was hit; and the world, drivers, seed, duration
    camera.mp4    the first car's camera

`output_paths()` checks --out and --record before the sim is built; `RunFolder` records and logs while the sim runs;
`RunFolder.finish()` writes the summary files and prints the summary. `run` writes to runs/<date-time>/ by default,
`teleop` and `launch` only where --out (or --record) says.
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import json
import math
import operator
import sys
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from racecar_sim.cli.args import check_folder, check_record_path, fresh_folder, make_folder
from racecar_sim.core.errors import ConfigError, NodeError, RecordingError, one_line
from racecar_sim.core.names import ODOM
from racecar_sim.nodes.guard import user_frames
from racecar_sim.runtime.run_log import RaceLog, RunLog, image_array, race_results

if TYPE_CHECKING:  # mcap, Pillow and PyAV load only when a run needs them
    from racecar_sim.recording.run_recording import RunRecording
    from racecar_sim.recording.video import VideoWriter
    from racecar_sim.recording.writer_process import ProcessVideo
    from racecar_sim.runtime import Simulator

MCAP, SUMMARY_PNG, SUMMARY_JSON, VIDEO = "run.mcap", "summary.png", "summary.json", "camera.mp4"
SHOWN_CRASHES = 3  # crashes listed by name in the printed summary, per car (summary.json has them all)
LABEL = 17  # the printed summary's label column


def output_paths(args: argparse.Namespace, default_out: Path | None) -> tuple[Path | None, Path | None]:
    """The run's folder (`default_out` without --out; None: no folder) and the MCAP path (None: no recording),
    checked before the sim is built: a bad --out or --record is one line, never a traceback after a minute of
    simulation."""
    out = Path(args.out) if args.out else default_out
    if args.no_record:
        record = None
    else:
        record = Path(args.record) if args.record else out / MCAP if out is not None else None
    if out is not None:
        check_folder("--out", out)
    if args.raw_images and record is None:
        why = "drop --no-record" if args.no_record else "give --out DIR or --record FILE.mcap"
        raise ConfigError(f"--raw-images says how camera images are recorded: {why}")
    if record is not None:  # in the default folder: that is a fresh one (RunFolder)
        check_record_path(record, overwrite=args.overwrite or (args.out is None and args.record is None))
    return out, record


@contextlib.contextmanager
def early_writer(args: argparse.Namespace, out: Path | None, record: Path | None) -> Iterator[None]:
    """Around the build of a run that records or films: its writer process started first, so that the child's start
    (a fresh interpreter importing its modules and encoders, ~0.3 s of CPU) runs on the core the build leaves idle,
    not beside the run; RunFolder takes it. Where it films, the child loads the compiled colour conversion too (numba:
    ~0.45 s) that saves the JPEG and the video a conversion each frame. One nobody took (the build failed) is closed
    at the end."""
    films = out is not None and not args.no_video and not getattr(args, "no_camera", False)
    if record is None and not films:
        yield
        return
    from racecar_sim.recording.writer_process import close_early, start_early

    start_early(colour=films)
    try:
        yield
    finally:
        close_early()


class RunFolder:
    """A run's files and logs while the sim runs: the recording, the video, a RunLog per car and the RaceLog.

    Made once the sim is built (its drivers on), before it runs; `close()` when it stops (the video and the
    recording finished, even after an error); `finish()` after, for the summary. The default folder
    (runs/<date-time>) is a fresh one, made only when something goes in it.
    """

    def __init__(self, args: argparse.Namespace, sim: Simulator, out: Path | None, record: Path | None) -> None:
        self.args, self.sim = args, sim
        self._closed = False
        self._scan: tuple[np.ndarray, np.ndarray] | None = None
        camera = sim.car.camera
        self.writes_summary = out is not None and not args.no_summary
        files = self.writes_summary or (out is not None and camera is not None and not args.no_video)
        out, record = _make_folder(args, out, record, files)
        self.out, self.record = out, record
        self.recording = _recording(args, sim, record)
        self.video: VideoWriter | ProcessVideo | None = None
        self.written: list[Path] = [record] if record is not None else []
        try:
            self.runlogs = [
                RunLog(
                    sim.bus,
                    car.lidar.topic if car.lidar else None,
                    car.camera.spec.image_topic if car.camera and i == 0 and self.writes_summary else None,
                    odom_topic=car.topic(ODOM),
                )
                for i, car in enumerate(sim.cars)
            ]
            self.race = RaceLog(sim)
            if out is not None and files and not args.no_video:
                self.video = _video(sim, out, self.recording)
        except BaseException:
            self.close(summary_frame=False)
            raise

    def close(self, summary_frame: bool = True) -> None:
        """Finish the video and the recording (what the writer process holds, then the MCAP's summary and footer);
        keep the first car's last scan for the summary while the sim still has its lidar, and its camera's last
        frame (drawn now where none was published; not with `summary_frame` False: the run ends in an error, and no
        summary follows). Once only."""
        if self._closed:
            return
        self._closed = True
        try:
            if self.video is not None:
                path = self.video.close()
                if self.video.frames:
                    self.written.append(path)
        finally:
            if self.recording is not None:
                self.recording.close()
        runlog, lidar = self.runlogs[0] if getattr(self, "runlogs", None) else None, self.sim.car.lidar
        if runlog is not None and lidar is not None and runlog.last_scan is not None:
            origin, ends = lidar.beam_ends(runlog.last_scan.ranges)
            self._scan = (origin[:2], ends[:, :2])
        camera = self.sim.car.camera
        if runlog is not None and camera is not None and self.writes_summary and summary_frame:
            runlog.take_frame(camera, self.sim.time_ns)  # the summary's frame, where none was published

    def __enter__(self) -> RunFolder:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, *exc: object) -> None:
        self.close(summary_frame=exc_type is None)

    # --- after the run ------------------------------------------------------------------------------------------
    def finish(
        self,
        title: str,
        header: Sequence[str],
        wall: float,
        drivers: Sequence[str],
        extra: dict[str, Any] | None = None,
        poses: bool = True,
    ) -> None:
        """Write summary.png and summary.json (unless --no-summary or no folder) and print the summary: `header`
        lines, the figures, the final poses (unless `poses` is False: the caller printed them) and the files
        written. `drivers`: each car's driver, as shown; `extra`: more fields for summary.json."""
        lines = self.summary_lines(wall)
        if self.writes_summary and self.out is not None:
            from racecar_sim.plots.summary import save_summary  # matplotlib loads only when a summary is drawn

            sim, runlog = self.sim, self.runlogs[0]
            fleet = len(sim.cars) > 1 or bool(sim.cars[0].name)
            paths = (
                {car.model_name: log.trajectory for car, log in zip(sim.cars, self.runlogs)}
                if fleet
                else runlog.trajectory
            )
            line = sim.laps.line if sim.laps is not None else None
            png = save_summary(
                self.out / SUMMARY_PNG,
                sim.world,
                paths,
                scan_origin=None if self._scan is None else self._scan[0],
                scan_points=None if self._scan is None else self._scan[1],
                camera_bgr=runlog.last_frame(),
                title=title,
                lines=lines,
                rate=runlog.trajectory_rate,
                crashes=self.race.crashes,
                laps=self.race.laps,
                start_line=None if line is None else (line.a, line.b),
            )
            summary = self.out / SUMMARY_JSON
            summary.write_text(json.dumps(_json_safe(self.summary_data(wall, drivers, extra)), indent=2) + "\n")
            self.written[:0] = [png, summary]
        for text in header:
            print(text)
        print(f"{'sim time':<{LABEL}}{self.sim.time:.2f} s")
        for text in lines:
            print(text)
        for car, log in zip(self.sim.cars, self.runlogs):
            if poses and log.last_pose is not None:
                x, y, yaw = log.last_pose
                label = "final pose" if len(self.sim.cars) == 1 and not car.name else f"{car.model_name} final pose"
                print(f"{label:<{LABEL}}x {x:.3f} m, y {y:.3f} m, yaw {yaw:.3f} rad")
        for path in self.written:
            print(f"{'wrote':<{LABEL}}{path}")

    def summary_lines(self, wall: float) -> list[str]:
        """The summary's figures: the single car's as always, or a row per car of a fleet; then laps and crashes."""
        sim, runlogs = self.sim, self.runlogs
        rtf = f"{'real-time factor':<{LABEL}}{sim.time / max(wall, 1e-9):.1f}x"
        results = [race_results(sim, car.model_name) for car in sim.cars]
        if len(sim.cars) == 1 and not sim.cars[0].name:
            runlog = runlogs[0]
            lines = [
                f"{'distance':<{LABEL}}{runlog.distance:.1f} m",
                f"{'mean speed':<{LABEL}}{runlog.mean_speed:.2f} m/s",
                rtf,
            ]
            if runlog.last_scan is not None:
                lines.append(f"{'min clearance':<{LABEL}}{runlog.min_clearance:.2f} m (lidar)")
            return lines + _race_lines("", results[0], sim.laps is not None)
        lines = [rtf, f"{'car':<6}{'distance':>10}{'mean speed':>12}{'min clearance':>15}{'laps':>6}{'crashes':>9}"]
        for car, log, result in zip(sim.cars, runlogs, results):
            clearance = f"{log.min_clearance:.2f} m" if log.last_scan is not None else "-"
            laps = "-" if result["laps"] is None else str(result["laps"])
            lines.append(
                f"{car.model_name:<6}{log.distance:>8.1f} m{log.mean_speed:>8.2f} m/s{clearance:>15}{laps:>6}"
                f"{result['crash_count']:>9}"
            )
        for car, result in zip(sim.cars, results):
            lines += _race_lines(f"{car.model_name} ", result, sim.laps is not None, fleet=True)
        if sim.laps is None:
            lines.append(_NO_START_LINE)
        return lines

    def summary_data(self, wall: float, drivers: Sequence[str], extra: dict[str, Any] | None = None) -> dict[str, Any]:
        """What summary.json holds."""
        sim = self.sim
        line = sim.laps.line if sim.laps is not None else None
        cars: dict[str, Any] = {}
        for car, log, driver in zip(sim.cars, self.runlogs, drivers):
            pose = None if log.last_pose is None else dict(zip(("x", "y", "yaw"), log.last_pose))
            cars[car.model_name] = {
                "driver": driver,
                "distance": log.distance,
                "mean_speed": log.mean_speed,
                "min_clearance": log.min_clearance if log.last_scan is not None else None,
                "final_pose": pose,
                **race_results(sim, car.model_name),
            }
        return {
            "world": sim.world.name,
            "driver": driver_label(sim, drivers),
            "seed": sim.seed,
            "duration": sim.time,
            "wall_time": wall,
            "real_time_factor": sim.time / wall if wall > 0 else None,
            "physics": sim.preset.name,
            "start_line": None if line is None else [list(line.a), list(line.b)],
            **(extra or {}),
            "cars": cars,
        }


_NO_START_LINE = f"{'laps':<{LABEL}}not counted: the world has no start line (--start-line X1,Y1,X2,Y2 gives one)"


def _race_lines(prefix: str, result: dict[str, Any], counted: bool, fleet: bool = False) -> list[str]:
    """Laps (each lap's time, the best) and crashes (how many, the first few with their times and what was hit)."""
    lines = []
    if counted and (result["laps"] or not fleet):
        times = result["lap_times"]
        text = str(result["laps"])
        if times:
            shown = ", ".join(f"{t:.2f} s" for t in times[:10]) + (", ..." if len(times) > 10 else "")
            text += f": {shown} (best {result['best_lap']:.2f} s)"
        lines.append(f"{prefix + 'laps':<{LABEL}}{text}")
    elif not counted and not fleet:
        lines.append(_NO_START_LINE)
    crashes = result["crashes"]
    if crashes or not fleet:
        text = str(result["crash_count"])
        if crashes:
            shown = "; ".join(f"{c['time']:.2f} s {c['what']}" for c in crashes[:SHOWN_CRASHES])
            more = f"; {len(crashes) - SHOWN_CRASHES} more" if len(crashes) > SHOWN_CRASHES else ""
            text += f": {shown}{more}"
        lines.append(f"{prefix + 'crashes':<{LABEL}}{text}")
    return lines


def driver_label(sim: Simulator, drivers: Sequence[str]) -> str:
    """One name for the run's drivers (the title's, the printed header's): the one every car has, or each car's."""
    if len(set(drivers)) <= 1:
        return drivers[0] if drivers else "none"
    return ", ".join(f"{car.model_name} {driver}" for car, driver in zip(sim.cars, drivers))


def _make_folder(
    args: argparse.Namespace, out: Path | None, record: Path | None, files: bool
) -> tuple[Path | None, Path | None]:
    """Make the run's folder where it gets `files` (summary, video) or the recording: the default runs/<date-time>
    is a fresh folder (runs/<date-time>-2 if another run has that one), so no two runs share it."""
    if out is None:
        return None, record
    default_record = record is not None and args.record is None
    if args.out is None and (files or default_record):
        out = fresh_folder("--out", out)
        return out, out / MCAP if default_record else record
    if files:
        make_folder("--out", out)
    return out, record


def _recording(args: argparse.Namespace, sim: Simulator, record: Path | None) -> RunRecording | None:
    """The run's MCAP, written by a writer process; camera images as JPEG CompressedImage unless --raw-images."""
    if record is None:
        return None
    from racecar_sim.recording.run_recording import RunRecording  # mcap and Pillow load only when a run records

    make_folder("--record", record.parent)
    image_topics = [car.camera.spec.image_topic for car in sim.cars if car.camera is not None]
    clock = functools.partial(operator.attrgetter("time_ns"), sim.loop)  # sim.time_ns: no Python call per message
    try:
        return RunRecording(
            sim.bus,
            clock,
            record,
            image_topics=image_topics,
            raw_images=args.raw_images,
            overwrite=args.overwrite,
        )
    except RecordingError as exc:  # taken by another run since the look before the build, or cannot be created
        raise RecordingError(f"--record {exc}") from None


def _video(sim: Simulator, out: Path, recording: RunRecording | None) -> VideoWriter | ProcessVideo | None:
    """camera.mp4, encoded by the recording's writer process (each frame crosses to it once), by a process of its
    own without a recording, or on a writer thread where no process can start."""
    if sim.car.camera is None:
        return None
    from racecar_sim.recording.writer_process import ProcessVideo, WriterProcess

    spec = sim.car.camera.spec
    path = out / VIDEO
    process = getattr(recording, "process", None)
    owns = process is None
    if owns:
        try:
            process = WriterProcess.open(f"video {path}")
        except OSError:
            process = None
    if process is None:
        from racecar_sim.recording.video import VideoWriter  # PyAV loads only when a video is written

        writer = VideoWriter(path, spec.rate_hz, spec.width, spec.height, background=True)
        sim.subscribe(spec.image_topic, lambda msg: writer.write(image_array(msg)))
        return writer
    video = ProcessVideo(process, path, spec.rate_hz, spec.width, spec.height, owns_process=owns)
    sim.subscribe(spec.image_topic, video.write_image)
    return video


def _json_safe(value: Any) -> Any:
    """Strict JSON: NaN and infinities (nothing measured) as null, tuples as lists, numpy scalars as numbers."""
    if isinstance(value, dict):
        return {key: _json_safe(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_safe(item) for item in value]
    if hasattr(value, "item"):
        value = value.item()
    return None if isinstance(value, float) and not math.isfinite(value) else value


def interrupted_note(sim: Simulator) -> None:
    """The line an interrupted run ends with."""
    print(f"racecar-sim: interrupted at sim time {sim.time:.2f} s; the files above are complete", file=sys.stderr)


def node_failure_fields(error: NodeError) -> dict[str, Any]:
    """What summary.json adds for a run a user's node stopped: `ended` "error" and the error's particulars."""
    cause = error.__cause__
    return {
        "ended": "error",
        "error": {
            "node": error.node,
            "car": error.car,
            "time": error.time,
            "in": error.where,
            "exception": f"{type(cause).__name__}: {one_line(cause)}" if cause is not None else str(error),
        },
    }


def node_failure_title(title: str, error: NodeError) -> str:
    """summary.png's title for a run a user's node stopped."""
    cause = type(error.__cause__).__name__ if error.__cause__ is not None else "an error"
    return f"{title}\nstopped at {error.time:.2f} s: {error.node} raised {cause}"


def node_failure_note(error: NodeError) -> None:
    """The lines a run a user's node stopped ends with: one naming the node, its car, the exception and the sim time,
    then the traceback of the node's own frames."""
    print(f"racecar-sim: error: {error}; the run stopped there (the files above hold it up to then)", file=sys.stderr)
    print(user_frames(error), file=sys.stderr, end="")
