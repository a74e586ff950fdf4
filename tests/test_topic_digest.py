"""Every message of three fixed-seed runs is the same, byte for byte and stamp for stamp, as on the commit before the
node-contract change (tests/data/topic_digests.json, written there by `python tests/topic_digest.py`): the original car
for 10 s with lidar and camera in walker, and a 4-car fleet in the tunnel; and 3 s of the original car with its camera
images recorded raw, written at cf9a246 (before issue 25's camera work). Reshaping the code must not change a run.

Camera images depend on the OpenGL renderer and the JPEG encoder's build: the JPEG topic is compared only where both are
the ones the digest was taken with (its digest was retaken when the encoder became simplejpeg: the frames it encodes
are pinned bit for bit by the raw run), the raw images wherever the renderer is the same."""

from __future__ import annotations

import json

import pytest

from topic_digest import CAMERA_MARK, DATA, RAW_IMAGES, RUNS, renderer, run_digest, same_drawing

EXPECTED = json.loads((DATA / "topic_digests.json").read_text())


@pytest.mark.parametrize("name", sorted(RUNS))
def test_every_topic_is_unchanged(name, tmp_path):
    got = run_digest(tmp_path / name, RUNS[name])
    want = EXPECTED[name]
    here, there = renderer(), EXPECTED["renderer"]
    same_renderer = same_drawing(here, there) if name == RAW_IMAGES else here == there
    topics = [t for t in want if same_renderer or CAMERA_MARK not in t]
    assert sorted(t for t in got if t in topics or CAMERA_MARK not in t) == sorted(topics)
    for t in topics:
        if t.endswith("/robot_description"):  # the checkout's path is in it
            got[t], want[t] = {**got[t], "sha256": ""}, {**want[t], "sha256": ""}
    changed = [f"{t}: {got[t]['count']} messages, was {want[t]['count']}" for t in topics if got[t] != want[t]]
    assert not changed, "\n".join(changed)
