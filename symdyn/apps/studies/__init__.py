"""Studies: the chapter's analyses, simulations, controllers and optimal control.

Each submodule defines `STUDIES = {name: (summary, function)}`; a study
function takes an output folder, writes PNG figures and `summary.txt` there,
and returns the summary text.  `symdyn study NAME` runs one.
"""

from __future__ import annotations

import pkgutil
from importlib import import_module
from pathlib import Path
from typing import Callable


def registry() -> dict[str, tuple[str, Callable]]:
    """All studies, by name, from every submodule's STUDIES."""
    found: dict[str, tuple[str, Callable]] = {}
    for info in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
        if info.name.startswith("_"):
            continue
        found.update(getattr(import_module(f"{__name__}.{info.name}"), "STUDIES", {}))
    return found


def run(name: str, out_dir: Path) -> str:
    """Run study `name`, writing into out_dir/name; return its summary."""
    studies = registry()
    if name not in studies:
        raise KeyError(f"unknown study {name!r}: known studies are {', '.join(sorted(studies))}")
    folder = Path(out_dir) / name
    folder.mkdir(parents=True, exist_ok=True)
    return studies[name][1](folder)
