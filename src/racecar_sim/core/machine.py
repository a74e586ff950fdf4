"""The machine a figure was measured on, in one line: its CPU model and core count (benches print it beside
their ratios, since absolute speeds differ from one machine to the next)."""

from __future__ import annotations

import os
import platform
from pathlib import Path


def cpu_model() -> str:
    """The CPU's model name as the kernel reports it (/proc/cpuinfo), else what the platform module knows."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            key, _, value = line.partition(":")
            if key.strip() in ("model name", "Model", "Hardware", "cpu model") and value.strip():
                return " ".join(value.split())
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown CPU"


def machine_line() -> str:
    """`CPU <model>, <n> cores (<arch>)`: the line a bench prints above its figures."""
    return f"CPU {cpu_model()}, {os.cpu_count() or '?'} cores ({platform.machine() or 'unknown architecture'})"
