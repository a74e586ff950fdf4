"""A texture's RGBA pixels kept on disk (worlds/images.py, rgba_pixels): what a later read gives is PIL's decoding of
the same file bit for bit, a changed file is decoded again, a cut entry is decoded again, and
RACECAR_SIM_IMAGE_CACHE=0 neither reads nor writes."""

from __future__ import annotations

import os

import numpy as np
from PIL import Image

from racecar_sim.core.errors import WorldError
from racecar_sim.worlds.images import rgba_pixels


def _fail(message: str) -> WorldError:
    return WorldError(message)


def _pil(path):
    with Image.open(path) as image:
        return np.asarray(image.convert("RGBA"))


def test_kept_pixels_are_pils_bit_for_bit_and_follow_the_file(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    rng = np.random.default_rng(3)
    texture = tmp_path / "skin.png"
    Image.fromarray(rng.integers(0, 256, (37, 23, 3), dtype=np.uint8)).save(texture)  # RGB: converted to RGBA
    entries = tmp_path / "cache" / "racecar-sim" / "images"

    monkeypatch.setenv("RACECAR_SIM_IMAGE_CACHE", "0")
    assert np.array_equal(rgba_pixels(texture, _fail), _pil(texture))
    assert not entries.exists()
    monkeypatch.delenv("RACECAR_SIM_IMAGE_CACHE")

    decoded = rgba_pixels(texture, _fail)
    [entry] = entries.iterdir()
    kept = rgba_pixels(texture, _fail)
    assert kept.shape == (37, 23, 4) and kept.dtype == np.uint8
    assert np.array_equal(kept, decoded) and np.array_equal(kept, _pil(texture))

    Image.fromarray(rng.integers(0, 256, (37, 23, 4), dtype=np.uint8)).save(texture)  # the file changes
    os.utime(texture, ns=(1, 1))
    assert np.array_equal(rgba_pixels(texture, _fail), _pil(texture))

    for old in entries.iterdir():
        old.write_bytes(old.read_bytes()[:-5])  # cut: decoded again, and kept whole again
    assert np.array_equal(rgba_pixels(texture, _fail), _pil(texture))
    assert np.array_equal(rgba_pixels(texture, _fail), _pil(texture))
    assert entry.exists()
