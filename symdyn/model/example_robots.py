"""Where example-robot-data's robot files lie: the `robots` extra's URDFs (Solo 12, Talos, Go2 …),
which studies, benchmarks and scripts read as a user's files."""

from __future__ import annotations

import importlib.metadata
from pathlib import Path

__all__ = ["robots_folder"]


def robots_folder() -> Path:
    """example-robot-data's robots/ folder (its wheel's cmeel.prefix).

    Raises:
        FileNotFoundError: example-robot-data is not installed (pip install 'symdyn[robots]').
    """
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        raise FileNotFoundError(
            "example-robot-data is not installed: pip install 'symdyn[robots]' (or example-robot-data)"
        ) from None
    return Path(dist.locate_file("cmeel.prefix/share/example-robot-data/robots"))
