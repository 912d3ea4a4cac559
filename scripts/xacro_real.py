"""Real xacro descriptions through `Robot.from_urdf` (issue 34, item 1): a slow, optional check.

Run: .venv/bin/python scripts/xacro_real.py [FILE.xacro[:arg:=value,…] …] [--package-path DIR …]
With no file it reads every .xacro file that ships in example-robot-data
(installed with symdyn's `robots` extra; offline, that is all there is: the
ROS descriptions of UR, Franka and Kinova are not on PyPI) and any found
below each --package-path.  Each line: the file, its arguments, then the
robot (joints, links on the chain, expansion + reading time) or the error
symdyn gives — a file that is not an arm (a quadrotor, a macro library with
no <robot> content) is expected to be refused with a message that says why.
"""

from __future__ import annotations

import sys
import time
import warnings
from pathlib import Path


def _files(package_paths: list[str]) -> list[Path]:
    found: list[Path] = []
    share = sorted(Path(sys.prefix).glob("lib/python3*/site-packages/cmeel.prefix/share/example-robot-data"))
    if share:
        found += sorted(share[0].rglob("*.xacro"))
    else:
        print("example-robot-data is not installed (pip install 'symdyn[robots]')")
    for folder in package_paths:
        found += sorted(Path(folder).rglob("*.urdf.xacro"))
    return found


def main(argv: list[str]) -> int:
    from symdyn.model import Robot

    files, package_paths, args = [], [], iter(argv)
    for item in args:
        if item == "--package-path":
            package_paths.append(next(args))
        else:
            files.append(item)
    jobs = []
    for item in files:
        path, _, spec = item.partition(":")
        xacro_args = dict(a.split(":=", 1) for a in spec.split(",") if a)
        jobs.append((Path(path), xacro_args))
    jobs = jobs or [(path, {}) for path in _files(package_paths)]
    if not jobs:
        print("no xacro file to read")
        return 0
    failures = 0
    for path, xacro_args in jobs:
        start = time.perf_counter()
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                robot = Robot.from_urdf(path, xacro_args=xacro_args, package_paths=package_paths)
        except ValueError as exc:
            failures += 1
            print(f"{path.name} {xacro_args or ''}: refused ({time.perf_counter() - start:.2f} s): {exc}")
            continue
        record = robot.urdf
        print(
            f"{path.name} {xacro_args or ''}: {robot.n} joints {record.joints}, chain {record.base_link} -> "
            f"{record.tip_link}, packages {record.packages}, {len(caught)} warnings, "
            f"{time.perf_counter() - start:.2f} s"
        )
    print(f"{len(jobs)} files, {len(jobs) - failures} read, {failures} refused")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
