"""Expanding a xacro file into URDF text in-process, with ROS's own xacro and our package folders.

The PyPI package `xacro` is ROS's xacro (the same code as in every ROS 2
install); alone it fails on `$(find pkg)` because it asks ROS's ament index.
Here its one lookup (`substitution_args._eval_find`, also `find()` inside
`${}`/`$(eval)`) and the folder of an included file are answered by
`Packages` (`--package-path`, `ROS_PACKAGE_PATH`, `AMENT_PREFIX_PATH`, the
folders above the file), for the length of one expansion and under a lock:
xacro keeps its state in module globals, so two expansions never overlap.
What xacro prints as warnings is re-issued as `URDFWarning`s; its errors
become `XacroError`s naming the file, and a missing `$(arg x)` or package
says how to supply it.
"""

from __future__ import annotations

import contextlib
import io
import os
import threading
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, Mapping

from ..xml import URDFError, URDFWarning
from .packages import PackageNotFound, Packages

__all__ = ["XacroError", "Expansion", "expand", "is_xacro"]

_LOCK = threading.Lock()
_INSTALL = "pip install 'symdyn[xacro]' (or pip install xacro)"


class XacroError(URDFError):
    """A xacro file that cannot be expanded.  `command_line` is the same message in the words
    of the command line (`--xacro-arg`, `--package-path` for `xacro_args=`, `package_paths=`)."""

    def __init__(self, message: str, command_line: str | None = None):
        super().__init__(message)
        self.command_line = command_line or message


@dataclass(frozen=True)
class Expansion:
    """The URDF text a xacro file expands to, the arguments given, and the packages it used (by name)."""

    text: str
    args: tuple
    packages: tuple


def is_xacro(path_or_text: str | os.PathLike[str], text: str | None = None) -> bool:
    """Whether a file (by its name, or its text declaring the xacro namespace) is xacro."""
    name = str(path_or_text)
    if "<" not in name and name.lower().endswith(".xacro"):
        return True
    return "xmlns:xacro" in (text if text is not None else name if "<" in name else "")


def _arguments(xacro_args: Mapping | None) -> dict:
    args = {}
    for key, value in dict(xacro_args or {}).items():
        if not isinstance(key, str) or not key.strip() or ":=" in key:
            raise XacroError(
                f"xacro argument name {key!r} must be a non-empty string (xacro_args={{'ur_type': 'ur5e'}})",
                f"--xacro-arg {key}: the name must be non-empty (e.g. --xacro-arg ur_type:=ur5e)",
            )
        if isinstance(value, bool):
            value = "true" if value else "false"
        args[key] = str(value)
    return args


def _missing_argument(exc: BaseException) -> str | None:
    """The name of the `$(arg …)` that had no value, if that is what `exc` (xacro's) is."""
    from xacro import substitution_args

    seen = set()
    while exc is not None and id(exc) not in seen:
        seen.add(id(exc))
        if isinstance(exc, substitution_args.ArgException):
            return str(exc.args[0]) if exc.args else str(exc)
        exc = getattr(exc, "exc", None) or exc.__cause__ or exc.__context__
    return None


def expand(
    path: str | os.PathLike[str] | None,
    *,
    text: str | None = None,
    xacro_args: Mapping | None = None,
    package_paths: Iterable[str | os.PathLike[str]] = (),
    source: str | None = None,
) -> Expansion:
    """The URDF text of the xacro file at `path` (its `text` when already read), or of the
    xacro `text` alone (its relative includes read from the working folder), expanded with `xacro_args` ({name: value},
    as `name:=value` on xacro's command line) and `$(find pkg)`/`package://pkg/`
    resolved by `Packages(package_paths, the file's folder)`.

    Raises:
        XacroError: (a `URDFError`, a `ValueError`) the `xacro` package is not installed;
            an argument used without a value or default (named, with how to give it); a
            package found nowhere (named, with every place looked in); any other xacro
            error (unknown macro, bad expression, missing include), with the file.
    """
    try:
        import xacro
        from xacro import substitution_args
    except ImportError:
        raise XacroError(
            f"{source or path}: reading a xacro file needs the xacro package: {_INSTALL}; "
            "or expand it with ROS's xacro (xacro FILE > FILE.urdf) and pass the .urdf"
        ) from None
    args = _arguments(xacro_args)
    start = Path(path).resolve().parent if path is not None else Path.cwd()
    packages = Packages(package_paths, start)
    name = source or (str(path) if path is not None else "<xacro string>")
    failures: list[BaseException] = []

    def find(package: str) -> str:
        try:
            return str(packages.find(package))
        except PackageNotFound as exc:
            failures.append(exc)
            raise

    original_abs = xacro.abs_filename_spec

    def abs_filename_spec(spec: str) -> str:
        if spec.startswith("package://"):
            try:
                return packages.resolve_uri(spec)
            except PackageNotFound as exc:
                failures.append(exc)
                raise
        return original_abs(spec)

    stderr = io.StringIO()
    with _LOCK:
        saved = substitution_args._eval_find, substitution_args._eval_dict.get("find"), xacro.abs_filename_spec
        substitution_args._eval_find = substitution_args._eval_dict["find"] = find
        xacro.abs_filename_spec = abs_filename_spec
        try:
            with contextlib.redirect_stderr(stderr):
                # process_file's steps without its banner, which names the file's folder
                xacro.init_stacks(str(path) if path is not None else None)
                doc = xacro.parse(text, str(path) if path is not None else None)
                xacro.process_doc(doc, mappings=dict(args))
            expanded = doc.toxml()
        except Exception as exc:
            error = _error(exc, name, failures, _missing_argument(exc), stderr.getvalue())
            raise error from None
        finally:
            substitution_args._eval_find, substitution_args._eval_dict["find"], xacro.abs_filename_spec = saved
    for line in stderr.getvalue().splitlines():
        line = line.strip()
        if line:
            warnings.warn(f"{name}: xacro: {line.removeprefix('warning: ')}", URDFWarning, stacklevel=3)
    return Expansion(expanded, tuple(args.items()), tuple(sorted(packages.found)))


def _error(exc: Exception, name: str, failures: list, missing: str | None, printed: str) -> XacroError:
    if failures:
        failure = failures[-1]
        message = f"{name}: {failure}"
        return XacroError(
            message + "\nadd the folder that holds it: package_paths=['DIR']",
            message + "\nadd the folder that holds it: --package-path DIR",
        )
    if missing is not None:
        return XacroError(
            f"{name}: xacro argument {missing!r} has no value and no default: pass xacro_args={{{missing!r}: ...}}",
            f"{name}: xacro argument {missing!r} has no value and no default: pass --xacro-arg {missing}:=VALUE",
        )
    detail = " ".join(line.strip() for line in printed.splitlines() if line.strip())
    return XacroError(f"{name}: xacro: {exc}" + (f" ({detail})" if detail else ""))
