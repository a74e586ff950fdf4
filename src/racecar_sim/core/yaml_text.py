"""YAML read as yaml.safe_load reads it, through libyaml's parser where PyYAML was built with it (5-10x faster: the
YAML a run reads at start-up took ~40 ms in pure Python)."""

from __future__ import annotations

from typing import Any

import yaml

_FAST = getattr(yaml, "CSafeLoader", None)


def safe_load(text: str) -> Any:
    """The document in `text`, as yaml.safe_load gives it. One that libyaml refuses is read again in pure Python,
    so that the error (a yaml.YAMLError) quotes the offending line as it always did."""
    if _FAST is not None:
        try:
            return yaml.load(text, Loader=_FAST)
        except yaml.YAMLError:
            pass
    return yaml.safe_load(text)
