"""The CPU line a bench prints above its figures: racecar_sim's own (core/machine.py), or, where the racecar_sim
measured is a checkout from before it had one (`PYTHONPATH=OLD/src python bench/...`), the platform's."""

from __future__ import annotations

import os
import platform


def machine_line() -> str:
    """`CPU <model>, <n> cores (<arch>)`."""
    try:
        from racecar_sim.core.machine import machine_line as line
    except ImportError:
        return f"CPU {platform.processor() or 'unknown model'}, {os.cpu_count() or '?'} cores ({platform.machine()})"
    return line()
