"""The writer process behind a run's recording and video: the same files as writing in place, byte for byte; each
camera image crosses to it once; its errors, its death and a Ctrl-C to the whole process group are handled."""

from __future__ import annotations

import ast
import hashlib
import os
import pickle
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import av
import numpy as np
import pytest
from mcap.reader import make_reader
from PIL import Image as PilImage
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

from racecar_sim.bus import Bus
from racecar_sim.core.errors import RecordingError
from racecar_sim.msgs import Float64, Header, Image, JointControllerState
from racecar_sim.msgs.cdr_layout import CdrLayout
from racecar_sim.recording import writer_process
from racecar_sim.recording.hand_overs import framed
from racecar_sim.recording.images import decompress_image
from racecar_sim.recording.run_recording import RunRecording
from racecar_sim.recording.video import VideoWriter
from racecar_sim.recording.writer_process import ProcessVideo, WriterProcess

IMAGE = "/camera/zed/rgb/image_rect_color"
COMPRESSED = IMAGE + "/compressed"
HEIGHT, WIDTH = 48, 64
CLI = [sys.executable, "-m", "racecar_sim"]


def frame(i: int) -> np.ndarray:
    """Frame i: a gradient with a bright square 2*i px from the left edge (BGR)."""
    y, x = np.mgrid[0:HEIGHT, 0:WIDTH]
    bgr = np.stack([x * 3, y * 4, np.full_like(x, 60)], axis=-1).astype(np.uint8)
    bgr[10:26, 2 * i : 2 * i + 16] = (40, 220, 250)
    return bgr


def image(i: int) -> Image:
    return Image(Header.at(i * 33_000_000, "camera_link"), HEIGHT, WIDTH, "bgr8", 0, WIDTH * 3, frame(i).reshape(-1))


def publish_run(bus: Bus, clock: list[int], frames: int = 10) -> None:
    """Messages of a run: a command every 10 ms, a camera image every 33 ms, stamped in sim time."""
    for tick in range(frames * 33 // 10 + 1):
        clock[0] = tick * 10_000_000
        bus.publish("/command", Float64(tick * 0.5))
        if tick * 10 // 33 < frames and tick * 10 % 33 < 10:
            bus.publish(IMAGE, image(tick * 10 // 33))


def record(path: Path, process: bool, **options) -> RunRecording:
    bus, clock = Bus(), [0]
    with RunRecording(bus, lambda: clock[0], path, image_topics=[IMAGE], process=process, **options) as rec:
        publish_run(bus, clock)
    return rec


def test_process_writes_the_bytes_the_thread_writes(tmp_path):
    by_thread = record(tmp_path / "thread.mcap", process=False)
    by_process = record(tmp_path / "process.mcap", process=True)
    assert by_thread.process is None and by_process.process is not None
    assert by_process.process.closed and by_process.process._process.returncode == 0  # waited for: no zombie
    data = (tmp_path / "process.mcap").read_bytes()
    assert data == (tmp_path / "thread.mcap").read_bytes() and len(data) > 5000
    for raw in (False, True):  # and raw images, serialized in the parent
        record(tmp_path / f"raw_{raw}.mcap", process=raw, raw_images=True)
    assert (tmp_path / "raw_True.mcap").read_bytes() == (tmp_path / "raw_False.mcap").read_bytes()


def test_a_process_started_early_records_the_same_bytes_and_one_left_unused_exits(tmp_path):
    record(tmp_path / "fresh.mcap", process=True)
    writer_process.start_early()
    early = writer_process._early
    assert early is not None and early._process.poll() is None  # its child starts before any file is opened
    rec = record(tmp_path / "early.mcap", process=True)
    assert rec.process is early and writer_process._early is None  # taken, the recording's file passed to it later
    assert (tmp_path / "early.mcap").read_bytes() == (tmp_path / "fresh.mcap").read_bytes()
    writer_process.start_early()
    unused = writer_process._early
    assert unused is not None
    writer_process.close_early()
    assert writer_process._early is None and unused.closed and unused._process.returncode is not None


@pytest.mark.parametrize(
    ("options", "record", "out", "started"),
    [
        ({}, True, True, [True]),  # the main job: records and films, the colour kernel loaded as the child starts
        ({"no_video": True}, True, True, [False]),
        ({"no_camera": True}, False, True, []),
        ({"no_video": True}, False, True, []),
        ({}, False, False, []),
    ],
)
def test_the_cli_starts_its_writer_process_before_the_build_where_the_run_writes_files(
    monkeypatch, tmp_path, options, record, out, started
):
    from argparse import Namespace

    from racecar_sim.cli.run_folder import early_writer

    calls: list[bool] = []
    monkeypatch.setattr(writer_process, "start_early", lambda colour=False: calls.append(colour))
    monkeypatch.setattr(writer_process, "close_early", lambda: calls.append(None))  # type: ignore[arg-type]
    args = Namespace(**{"no_video": False, "no_camera": False} | options)
    with early_writer(args, tmp_path if out else None, tmp_path / "run.mcap" if record else None):
        assert calls == started
    assert calls == (started + [None] if started else [])


def test_recorded_jpegs_decode_to_the_published_frames_in_publication_order(tmp_path):
    record(tmp_path / "run.mcap", process=True)
    with open(tmp_path / "run.mcap", "rb") as f:
        topics = [channel.topic for _, channel, _ in make_reader(f).iter_messages(log_time_order=False)]
    assert topics[:4] == ["/command", IMAGE + "/compressed", "/command", "/command"]
    with AnyReader([tmp_path / "run.mcap"], default_typestore=get_typestore(Stores.EMPTY)) as reader:
        images = [c for c in reader.connections if c.topic == COMPRESSED]
        messages = [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages(connections=images)]
    assert len(messages) == 10
    for i, msg in enumerate(messages):
        assert msg.header.stamp.nanosec == i * 33_000_000 and msg.format == "bgr8; jpeg compressed bgr8"
        error = decompress_image(msg).astype(float) - frame(i)
        assert 10 * np.log10(255.0**2 / np.mean(error**2)) > 30.0  # PSNR


def test_an_image_both_recorded_and_filmed_crosses_once_and_the_video_is_the_in_place_one(tmp_path):
    bus, clock = Bus(), [0]
    rec = RunRecording(bus, lambda: clock[0], tmp_path / "run.mcap", image_topics=[IMAGE])
    video = ProcessVideo(rec.process, tmp_path / "camera.mp4", 30.0, WIDTH, HEIGHT)
    bus.subscribe(IMAGE, video.write_image)
    sent: list[object] = []
    real_image = rec.process.image
    rec.process.image = lambda msg: sent.append(real_image(msg)) or sent[-1]  # type: ignore[method-assign]
    publish_run(bus, clock)
    assert video.close() == tmp_path / "camera.mp4" and video.frames == 10
    rec.close()
    assert len(sent) == 20 and sum(s is not None for s in sent) == 10  # pixels once, then "the same image"

    with VideoWriter(tmp_path / "in_place.mp4", 30.0, WIDTH, HEIGHT) as in_place:
        for i in range(10):
            in_place.write(frame(i))
    decoded = []
    for path in (tmp_path / "camera.mp4", tmp_path / "in_place.mp4"):
        with av.open(str(path)) as container:
            decoded.append([f.to_ndarray(format="bgr24") for f in container.decode(video=0)])
    assert len(decoded[0]) == 10 and all(np.array_equal(a, b) for a, b in zip(*decoded))


def big_image(i: int) -> Image:
    """A 640x480 frame (large enough to cross in shared memory): frame(i) scaled up 10 times."""
    pixels = np.ascontiguousarray(frame(i).repeat(10, axis=0).repeat(10, axis=1))
    return Image(Header.at(i * 33_000_000, "camera_link"), 480, 640, "bgr8", 0, 640 * 3, pixels.reshape(-1))


def record_and_film(tmp_path: Path, process: bool, images: list[Image]) -> bytes:
    """The MCAP bytes of a recording of `images` (JPEG, by a writer process or in place), filmed to camera.mp4 by the
    same process, or to in_place.mp4 by a VideoWriter."""
    bus, clock = Bus(), [0]
    rec = RunRecording(bus, lambda: clock[0], tmp_path / f"run_{process}.mcap", image_topics=[IMAGE], process=process)
    if process:
        video = ProcessVideo(rec.process, tmp_path / "camera.mp4", 30.0, 640, 480)
        bus.subscribe(IMAGE, video.write_image)
    else:
        in_place = VideoWriter(tmp_path / "in_place.mp4", 30.0, 640, 480)
        bus.subscribe(IMAGE, lambda msg: in_place.write(msg.bgr_pixels()))
    for i, msg in enumerate(images):
        clock[0] = i * 33_000_000
        bus.publish("/command", Float64(i))
        bus.publish(IMAGE, msg)
    if process:
        ring = rec.process._ring
        assert ring is not None and ring.next == len(images) and ring.slots == 3  # every frame went by the ring
        video.close()
    else:
        in_place.close()
    rec.close()
    return (tmp_path / f"run_{process}.mcap").read_bytes()


def test_camera_frames_cross_in_shared_memory_and_the_files_are_the_in_place_ones(tmp_path, monkeypatch):
    """Each frame is copied into a ring of slots the child lets go of in turn; with 3 slots and 12 frames the parent
    reuses each slot 4 times (waiting for the child where it is behind), and no frame is overwritten too early."""
    monkeypatch.setattr(writer_process, "RING_SLOTS", 3)
    images = [big_image(i) for i in range(12)]
    assert record_and_film(tmp_path, True, images) == record_and_film(tmp_path, False, images)
    decoded = []
    for path in (tmp_path / "camera.mp4", tmp_path / "in_place.mp4"):
        with av.open(str(path)) as container:
            decoded.append([f.to_ndarray(format="bgr24") for f in container.decode(video=0)])
    assert len(decoded[0]) == 12 and all(np.array_equal(a, b) for a, b in zip(*decoded))


def test_a_process_started_to_film_converts_each_frame_once_for_the_same_jpegs_and_a_video_within_2_levels(
    tmp_path, monkeypatch
):
    monkeypatch.setattr(writer_process, "RING_SLOTS", 3)
    images = [big_image(i) for i in range(6)]
    in_place = record_and_film(tmp_path, False, images)
    writer_process.start_early(colour=True)  # as `racecar-sim run` does: the colour kernel loaded as it starts
    assert record_and_film(tmp_path, True, images) == in_place  # the JPEGs from the kernel's planes: the same bytes
    decoded = []
    for path in (tmp_path / "camera.mp4", tmp_path / "in_place.mp4"):
        with av.open(str(path)) as container:
            decoded.append([f.to_ndarray(format="yuv420p").astype(int) for f in container.decode(video=0)])
    assert len(decoded[0]) == 6
    luma = np.array([np.abs(a[:480] - b[:480]).mean() for a, b in zip(*decoded)])
    chroma = np.array([np.abs(a[480:] - b[480:]).mean() for a, b in zip(*decoded)])
    assert chroma.max() > 0  # not libswscale's planes: the kernel's
    assert luma.max() < 0.5 and chroma.max() <= 2.0


def test_a_video_without_a_recording_owns_its_process_and_falls_back_to_gif(tmp_path, monkeypatch, caplog):
    fake = tmp_path / "site"
    fake.mkdir()
    (fake / "av.py").write_text("raise ImportError('no PyAV in this test')\n")
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([str(fake), os.environ.get("PYTHONPATH", "")]))
    video = ProcessVideo(WriterProcess("video"), tmp_path / "camera.mp4", 30.0, WIDTH, HEIGHT, owns_process=True)
    for i in range(6):
        video.write_image(image(i))
    assert video.close() == tmp_path / "camera.gif" and video.process.closed
    assert any("GIF" in r.getMessage() for r in caplog.records)  # the child's warning, logged here
    with PilImage.open(tmp_path / "camera.gif") as gif:
        assert gif.n_frames == 2  # 30 fps -> every third frame


def test_an_error_in_the_child_is_raised_by_a_later_publish_or_close_and_the_file_is_finished(tmp_path):
    bus, clock = Bus(), [0]
    rec = RunRecording(bus, lambda: clock[0], tmp_path / "run.mcap", image_topics=[IMAGE])
    bus.publish("/command", Float64(1.0))
    bus.publish(IMAGE, Image(Header(), 1, 1, "mono8", 0, 1, b"\x00"))  # the child cannot JPEG-compress it
    with pytest.raises(ValueError, match="cannot JPEG-compress a 'mono8' image"):
        for tick in range(100_000):
            clock[0] = tick
            bus.publish("/command", Float64(tick))
            time.sleep(1e-4)
    rec.close()  # raised once
    with AnyReader([tmp_path / "run.mcap"], default_typestore=get_typestore(Stores.EMPTY)) as reader:
        assert {c.topic: c.msgcount for c in reader.connections} == {"/command": 1}


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="needs /dev/full")
def test_a_full_disk_is_an_oserror_at_close():
    bus = Bus()
    rec = RunRecording(bus, lambda: 0, "/dev/full")
    bus.publish("/command", Float64(1.0))
    with pytest.raises(OSError, match="No space left"):
        rec.close()


def test_a_dead_child_is_an_error_not_a_hang(tmp_path):
    bus, clock = Bus(), [0]
    rec = RunRecording(bus, lambda: clock[0], tmp_path / "run.mcap", image_topics=[IMAGE])
    rec.process._process.kill()
    with pytest.raises(RecordingError, match="writer process exited"):
        publish_run(bus, clock, frames=200)
        rec.close()
    rec.close()


def test_a_path_that_cannot_be_written_raises_in_the_caller(tmp_path):
    with pytest.raises(RecordingError, match="cannot create the MCAP file"):
        RunRecording(Bus(), lambda: 0, tmp_path / "missing" / "run.mcap")


def test_without_a_process_it_records_on_a_thread(tmp_path, monkeypatch, caplog):
    def no_process(*args, **kwargs):
        raise OSError("no processes here")

    monkeypatch.setattr(writer_process.subprocess, "Popen", no_process)
    rec = record(tmp_path / "thread.mcap", process=True)
    assert rec.process is None and rec.recorder is not None and "writer thread" in caplog.text
    record(tmp_path / "again.mcap", process=False)
    assert (tmp_path / "thread.mcap").read_bytes() == (tmp_path / "again.mcap").read_bytes()


def test_a_script_without_a_main_guard_records(tmp_path):
    """The child is a fresh interpreter running only the writer: a user's script is not run again in it."""
    script = tmp_path / "script.py"
    script.write_text(
        "from racecar_sim.bus import Bus\nfrom racecar_sim.msgs import Float64\n"
        "from racecar_sim.recording import RunRecording\n"
        "print('script ran')\n"
        "bus = Bus()\n"
        f"with RunRecording(bus, lambda: 0, {str(tmp_path / 'run.mcap')!r}):\n"
        "    bus.publish('/command', Float64(1.0))\n"
    )
    result = subprocess.run([sys.executable, str(script)], check=False, capture_output=True, text=True, timeout=60)
    assert result.returncode == 0, result.stderr
    assert result.stdout.count("script ran") == 1 and (tmp_path / "run.mcap").stat().st_size > 500


@pytest.mark.skipif(os.name != "posix", reason="signals")
def test_ctrl_c_to_the_whole_process_group_still_finishes_the_files(tmp_path):
    """A terminal's Ctrl-C reaches every process of the group: the writer ignores it, the run closes it."""
    out = tmp_path / "run.mcap"
    proc = subprocess.Popen(
        [
            *CLI,
            "run",
            "--world",
            "empty",
            "--driver",
            "constant",
            "--duration",
            "3000",
            "--realtime",
            "--record",
            str(out),
            "--out",
            str(tmp_path),
            "--no-summary",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    deadline = time.time() + 60
    while time.time() < deadline and (not out.exists() or out.stat().st_size < 2000):
        time.sleep(0.2)
    time.sleep(1.5)
    os.killpg(proc.pid, signal.SIGINT)
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 130, stderr
    assert "Traceback" not in stderr
    with AnyReader([out], default_typestore=get_typestore(Stores.EMPTY)) as reader:
        assert sum(c.msgcount for c in reader.connections if c.topic == "/vesc/odom") >= 20


def _threads_nice(pid: int) -> dict[int, int]:
    """Each thread's nice value, as the kernel reports it (/proc/PID/task/TID/stat, field 19)."""
    nice = {}
    for task in Path(f"/proc/{pid}/task").iterdir():
        fields = task.joinpath("stat").read_text().rsplit(")", 1)[1].split()
        nice[int(task.name)] = int(fields[16])  # field 19 of the line, the 17th after the command's name
    return nice


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="per-thread nice values and SCHED_BATCH are Linux's")
def test_the_writer_gives_way_to_the_simulation_with_an_urgent_worker_at_its_priority(tmp_path):
    """The child is scheduled as batch work (woken simulation threads go first); its relaxed worker (the main thread)
    runs GIVE_WAY nice levels below the simulation, and its urgent worker, which takes over when the writer falls
    behind, at the simulation's priority (a writer nicer throughout starved beside other busy processes)."""
    bus, clock = Bus(), [0]
    rec = RunRecording(bus, lambda: clock[0], tmp_path / "run.mcap", image_topics=[IMAGE])
    pid = rec.process._process.pid
    ours = os.getpriority(os.PRIO_PROCESS, 0)
    relaxed = min(ours + writer_process.GIVE_WAY, 19)  # the kernel stops at 19
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline:  # the child sets them as it starts
        nice = _threads_nice(pid)
        if nice.get(pid) == relaxed and ours in nice.values():
            break
        time.sleep(0.05)
    assert nice[pid] == relaxed
    assert [tid for tid, n in nice.items() if n == ours], "no worker at the simulation's priority"
    assert all(os.sched_getscheduler(tid) == os.SCHED_BATCH for tid in nice)
    publish_run(bus, clock, frames=5)
    rec.close()


class _NiceRecorder:
    """_Workers' files, recording the nice value of the thread doing each operation."""

    def __init__(self) -> None:
        self.nice: list[int] = []
        self.reports = None

    def do_all(self, ops):
        for _ in ops:
            self.nice.append(os.getpriority(os.PRIO_PROCESS, 0))  # the calling thread's, on Linux


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="per-thread nice values are Linux's")
def test_the_urgent_worker_takes_the_hand_overs_while_the_writer_is_behind(monkeypatch):
    import pickle
    import queue
    import threading

    monkeypatch.setattr(writer_process, "BEHIND", 4)
    monkeypatch.setattr(writer_process, "CAUGHT_UP", 1)
    ours = os.getpriority(os.PRIO_PROCESS, 0)
    relaxed_nice = min(ours + writer_process.GIVE_WAY, 19)
    hand_over = (pickle.dumps([(writer_process.MESSAGE,)]), [])

    # behind: 12 hand-overs waiting at once
    hand_overs: queue.Queue = queue.Queue()
    for _ in range(12):
        hand_overs.put(hand_over)
    hand_overs.put(None)
    files = _NiceRecorder()
    workers = writer_process._Workers(hand_overs, files)
    urgent = threading.Thread(target=workers.work, args=(True,))
    urgent.start()  # before the other gives way, as serve() starts it
    relaxed = threading.Thread(target=lambda: writer_process._give_way() and workers.work(urgent=False))
    relaxed.start()
    for thread in (urgent, relaxed):
        thread.join(30)
    # the relaxed worker does the first; 11 wait, 4 or more: the urgent one does them until one is left (the end)
    assert files.nice == [relaxed_nice] + [ours] * 11
    assert workers.done == {False: 1, True: 11}

    # keeping up: each hand-over waits alone, and the relaxed worker does them all
    hand_overs = queue.Queue()
    files = _NiceRecorder()
    workers = writer_process._Workers(hand_overs, files)
    urgent = threading.Thread(target=workers.work, args=(True,))
    urgent.start()
    relaxed = threading.Thread(target=lambda: writer_process._give_way() and workers.work(urgent=False))
    relaxed.start()
    for i in range(6):
        hand_overs.put(hand_over)
        deadline = time.monotonic() + 10
        while len(files.nice) <= i and time.monotonic() < deadline:
            time.sleep(0.005)
    hand_overs.put(None)
    for thread in (urgent, relaxed):
        thread.join(30)
    assert files.nice == [relaxed_nice] * 6


def test_a_worker_that_dies_stops_the_other_instead_of_leaving_it_waiting_for_its_turn():
    """An error that escapes a hand-over (here the report pipe gone) ends both workers: the child then finishes its
    files and exits, rather than hang with one worker waiting for a turn that never comes."""
    import pickle
    import queue
    import threading

    class _BrokenReports:
        def send(self, kind, value):
            raise BrokenPipeError("the parent is gone")

    class _Failing:
        reports = _BrokenReports()

        def do(self, op):
            raise OSError("disk full")

    hand_overs: queue.Queue = queue.Queue()
    for _ in range(3):
        hand_overs.put((pickle.dumps([(writer_process.MESSAGE,)]), []))
    workers = writer_process._Workers(hand_overs, _Failing())
    escaped: list[BaseException] = []

    def work(urgent: bool) -> None:
        try:
            workers.work(urgent)
        except BaseException as exc:
            escaped.append(exc)

    threads = [threading.Thread(target=work, args=(urgent,), daemon=True) for urgent in (True, False)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(10)
    assert not any(thread.is_alive() for thread in threads), "a worker still waits for its turn"
    assert [type(exc) for exc in escaped] == [BrokenPipeError]
    assert workers.finished


def _states(tick: int) -> list[JointControllerState]:
    """Two controller states of sim time `tick` * 10 ms, their numbers all different from tick to tick."""
    return [
        JointControllerState(
            Header.at(tick * 10_000_000),
            tick + k,
            -tick / 3,
            0.0,
            k - tick / 7,
            0.0025,
            tick * 1e-3,
            1.0,
            0.5 * k,
            0.0,
            10.0,
            False,
        )  # fmt: skip
        for k in range(2)
    ]


def _record_states(path: Path, process: bool, rows: bool) -> bytes:
    """A command and two controller states every 10 ms, recorded; `rows`: the states handed over as their numbers and
    layout (Bus.publish_cdr_rows: the writer packs them), else as message objects."""
    bus, clock = Bus(), [0]
    topics = ("/car1/a/state", "/car1/b/state")
    layout = CdrLayout.read(_states(0)[0])
    assert layout is not None
    with RunRecording(bus, lambda: clock[0], path, process=process):
        for tick in range(3 * writer_process.BATCH):  # several hand-overs: the layout goes over once, then by number
            clock[0] = tick * 10_000_000
            bus.publish("/command", Float64(tick * 0.5))
            states = _states(tick)
            if rows:
                bus.publish_cdr_rows(JointControllerState, layout, topics, [CdrLayout.of(s)[1] for s in states])
            else:
                for topic, state in zip(topics, states):
                    bus.publish(topic, state)
    return path.read_bytes()


@pytest.mark.parametrize("process", [True, False])
def test_rows_packed_by_the_writer_are_the_bytes_of_the_messages(tmp_path, process):
    """Controller states handed over as their numbers, packed by the writer process (or on the parent's side for a
    writer thread): the file is byte for byte the one their message objects give, with every message in its place."""
    from_objects = _record_states(tmp_path / "objects.mcap", process, rows=False)
    from_rows = _record_states(tmp_path / "rows.mcap", process, rows=True)
    assert len(from_rows) > 20_000 and from_rows == from_objects


@pytest.mark.parametrize("colour", [False, True])
def test_the_child_freezes_what_its_imports_made_and_turns_the_collector_back_on(colour):
    # started as the child is (the collector off before its first import), the imports' objects (10^4-10^5: PyAV,
    # the MCAP writer, numba's load with the colour kernel) end up frozen, out of every later collection's way, and
    # the collector runs again for what the run makes
    code = (
        "import gc; gc.disable(); from racecar_sim.recording.writer_process import _import_encoders; "
        f"_import_encoders({colour}); print(gc.isenabled(), gc.get_freeze_count(), len(gc.get_objects()))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], env=writer_process._child_environment(), capture_output=True, text=True
    )
    enabled, frozen, tracked = out.stdout.split()
    assert enabled == "True"
    assert int(frozen) > 20_000
    assert int(tracked) < 1_000  # nothing left for a collection to walk


def test_the_child_reads_hand_overs_before_it_imports_the_writer_modules_and_drops_one_cut_off(tmp_path):
    # the child's first step (begin_child, as the writer's command runs it) reads the pipe at once: the parent hands
    # over three times the pipe's size while the child has imported nothing but the standard library and that module
    # (no numpy, mcap or message classes, which take it ~0.13 s), and each hand-over arrives whole, its pickle and
    # out-of-band buffers intact; a hand-over cut off half-way (the parent died) ends the reading with no partial one
    code = (
        "import sys, time; from racecar_sim.recording.hand_overs import begin_child; h = begin_child(); "
        "deadline = time.monotonic() + 60\n"
        "while h.qsize() < 7 and time.monotonic() < deadline: time.sleep(0.01)\n"
        "heavy = sorted(m for m in ('numpy', 'mcap', 'racecar_sim.msgs', 'racecar_sim.recording.writer_process') "
        "if m in sys.modules)\n"
        "import pickle, hashlib\n"
        "items = []\n"
        "while (item := h.get()) is not None:\n"
        "    ops = pickle.loads(item[0], buffers=item[1])\n"
        "    items.append([op[0], op[1], hashlib.sha256(bytes(op[2])).hexdigest()] for op in ops)\n"
        "print(repr((heavy, [list(i) for i in items])))"
    )
    read, write = os.pipe()
    child = subprocess.Popen(
        [sys.executable, "-c", code, str(read)],
        pass_fds=(read,),
        stdout=subprocess.PIPE,
        text=True,
        env=writer_process._child_environment(),
    )
    os.close(read)
    rng = np.random.default_rng(0)
    hand_overs = []
    for k in range(7):  # 7 x ~450 KB: more than three 1 MB pipes' worth; two messages each, one out of band
        big, small = rng.bytes(450_000 + k), rng.bytes(100 + k)
        ops = [("msg", k, pickle.PickleBuffer(big)), ("msg", k, small)]
        buffers: list[pickle.PickleBuffer] = []
        body = pickle.dumps(ops, 5, buffer_callback=buffers.append)
        hand_overs.append((framed(body, [b.raw() for b in buffers]), [big, small]))

    def hand_over_all() -> None:
        for pieces, _ in hand_overs:
            for piece in pieces:
                os.write(write, piece)
        cut = hand_overs[0][0]
        os.write(write, bytes(cut[0]) + bytes(cut[1]) + bytes(cut[2])[:1000])  # the last one cut off half-way
        os.close(write)

    parent = threading.Thread(target=hand_over_all, daemon=True)
    parent.start()
    out, _ = child.communicate(timeout=120)
    parent.join(timeout=10)
    heavy, items = ast.literal_eval(out)
    assert heavy == []
    assert items == [
        [["msg", k, hashlib.sha256(data).hexdigest()] for data in sent] for k, (_, sent) in enumerate(hand_overs)
    ]


def publish_frames_then_reuse_their_memory(bus: Bus, clock: list[int], frames: int) -> None:
    """A command and a camera image every 10 ms; after each publish the image's pixel array is drawn over (as a
    camera reusing its buffer would), where `frames` is negative: the recording must hold the frames as published."""
    for i in range(abs(frames)):
        clock[0] = i * 10_000_000
        bus.publish("/command", Float64(i * 0.5))
        msg = image(i % 20)
        bus.publish(IMAGE, msg)
        if frames < 0:
            msg.data[:] = 255


def test_the_run_goes_on_while_its_writer_cannot_read_and_the_file_is_the_same(tmp_path):
    # the child stopped (SIGSTOP: a child still importing, or behind), the run hands over twice the pipe's size and is
    # not held up: what the pipe cannot take waits in the parent (its images copied: their arrays are drawn over after
    # each publish here); once the child goes on, the file is byte for byte the one a writer thread makes of the same
    # frames left alone. A run held up on the pipe would never return here: the watchdog lets the child go on after
    # 60 s and the test fails.
    frames = 220  # x ~9.2 KB of pixels and the commands: ~2 MB, the pipe holds 1 MB
    bus, clock = Bus(), [0]
    with RunRecording(bus, lambda: clock[0], tmp_path / "thread.mcap", image_topics=[IMAGE], process=False):
        publish_frames_then_reuse_their_memory(bus, clock, frames)
    bus, clock = Bus(), [0]
    rec = RunRecording(bus, lambda: clock[0], tmp_path / "process.mcap", image_topics=[IMAGE], process=True)
    assert rec.process is not None
    child = rec.process._process
    child.send_signal(signal.SIGSTOP)
    watchdog = threading.Timer(60, child.send_signal, (signal.SIGCONT,))
    watchdog.start()
    try:
        publish_frames_then_reuse_their_memory(bus, clock, -frames)
        kept = rec.process._backlog.size
        assert watchdog.is_alive()  # the run was not held up
    finally:
        watchdog.cancel()
        child.send_signal(signal.SIGCONT)
    rec.close()
    assert kept > 500_000  # about what the pipe could not take
    assert (tmp_path / "process.mcap").read_bytes() == (tmp_path / "thread.mcap").read_bytes()


def test_a_writer_that_dies_mid_run_is_an_error_and_never_a_hang(tmp_path):
    # the child killed (SIGKILL: out of memory, say) while the pipe holds hand-overs and the parent keeps more: the
    # next hand-over the pipe refuses raises one RecordingError naming the writer process, and closing returns
    bus, clock = Bus(), [0]
    rec = RunRecording(bus, lambda: clock[0], tmp_path / "run.mcap", image_topics=[IMAGE], process=True)
    assert rec.process is not None
    child = rec.process._process
    child.send_signal(signal.SIGSTOP)
    publish_frames_then_reuse_their_memory(bus, clock, 150)  # the pipe full, the rest kept in the parent
    assert rec.process._backlog.size > 0
    child.kill()
    child.wait()
    with pytest.raises(RecordingError, match=r"writer process exited \(code -9\) before the files were finished"):
        for _ in range(100):  # the next hand-over meets the closed pipe
            publish_frames_then_reuse_their_memory(bus, clock, 10)
    rec.close()  # raised once already: closing returns
    assert rec.process.closed and rec.process._backlog.size == 0
