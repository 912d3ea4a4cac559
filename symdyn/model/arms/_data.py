"""Read the parameter tables shipped beside the model modules."""

from __future__ import annotations

import json
from importlib import resources


def read(name: str) -> dict:
    """The JSON table `data/<name>.json` (facts from the literature)."""
    return json.loads(resources.files(__package__).joinpath("data", f"{name}.json").read_text())
