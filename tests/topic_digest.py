"""A digest of every topic of a run's MCAP: what must not change when the code is reshaped or sped up.

Each channel's digest is SHA-256 over its messages in log order (log time, then the CDR bytes), plus the
message count and schema name; camera image topics are kept apart because their bytes depend on the
OpenGL renderer (Mesa's llvmpipe version) and on the JPEG encoder's build.
"""

from __future__ import annotations

import hashlib
import json
import subprocess
import sys
from pathlib import Path

from mcap.reader import make_reader

DATA = Path(__file__).parent / "data"
CAMERA_MARK = "/camera/"


def mcap_digest(path: Path) -> dict[str, dict[str, object]]:
    """{topic: {"schema", "count", "sha256"}} of every channel in the MCAP file."""
    hashes: dict[str, hashlib._Hash] = {}
    counts: dict[str, int] = {}
    schemas: dict[str, str] = {}
    with open(path, "rb") as f:
        reader = make_reader(f)
        for schema, channel, message in reader.iter_messages(log_time_order=True):
            topic = channel.topic
            if topic not in hashes:
                hashes[topic], counts[topic] = hashlib.sha256(), 0
                schemas[topic] = schema.name if schema is not None else ""
            hashes[topic].update(message.log_time.to_bytes(8, "little"))
            hashes[topic].update(len(message.data).to_bytes(8, "little"))
            hashes[topic].update(message.data)
            counts[topic] += 1
    return {t: {"schema": schemas[t], "count": counts[t], "sha256": hashes[t].hexdigest()} for t in sorted(hashes)}


def renderer() -> str:
    """What draws and encodes camera images here: the GL renderer, then (after "; ") the JPEG encoder's version."""
    from racecar_sim.core.errors import RenderingError

    try:
        from racecar_sim.render.gl import shared_context
    except ImportError:  # the checkout before GL moved out of sensors/
        from racecar_sim.render.gl import shared_context  # type: ignore[no-redef]
    try:
        gl = shared_context()
    except RenderingError:
        return "none"
    try:
        import simplejpeg

        encoder = f"simplejpeg {simplejpeg.__version__}"
    except ImportError:  # the checkouts before the encoder changed (tests/data was written with Pillow 13.0.0)
        import PIL

        encoder = f"Pillow {PIL.__version__}"
    return f"{gl.backend}: {gl.renderer}; {encoder}"


def same_drawing(here: str, there: str) -> bool:
    """Whether two renderer() strings draw the same images (the same GL renderer; the JPEG encoder aside)."""
    return here.split("; ")[0] == there.split("; ")[0]


def run_digest(
    out: Path, args: list[str], python: str = sys.executable, env: dict[str, str] | None = None
) -> dict[str, dict[str, object]]:
    """Run `racecar-sim run ARGS --out OUT --no-video --no-summary` and digest its run.mcap."""
    subprocess.run(
        [python, "-m", "racecar_sim", "run", *args, "--out", str(out), "--no-video", "--no-summary"],
        check=True,
        capture_output=True,
        text=True,
        env=env,
        timeout=600,
    )
    return mcap_digest(out / "run.mcap")


# the runs pinned: the original car for 10 s with every sensor, a 4-car fleet (lidar only), and 3 s of the original
# car's camera recorded raw (its frames bit for bit, whatever the JPEG encoder: written at cf9a246, before issue 25's
# camera work)
RUNS = {
    "original_car_walker_10s": ["--world", "walker", "--duration", "10", "--seed", "7"],
    "fleet4_tunnel_10s": ["--world", "tunnel", "--cars", "4", "--no-camera", "--duration", "10", "--seed", "3"],
    "original_car_walker_raw_images_3s": ["--world", "walker", "--duration", "3", "--seed", "7", "--raw-images"],
}
RAW_IMAGES = "original_car_walker_raw_images_3s"  # its camera topics need only the same GL renderer


if __name__ == "__main__":  # python tests/topic_digest.py OUTDIR: write tests/data/topic_digests.json
    import os
    import tempfile

    result: dict[str, object] = {"renderer": renderer()}
    with tempfile.TemporaryDirectory() as tmp:
        for name, run_args in RUNS.items():
            result[name] = run_digest(Path(tmp) / name, run_args, env=dict(os.environ))
    target = Path(sys.argv[1]) if len(sys.argv) > 1 else DATA / "topic_digests.json"
    target.write_text(json.dumps(result, indent=1, sort_keys=True) + "\n")
    print(f"wrote {target}")
