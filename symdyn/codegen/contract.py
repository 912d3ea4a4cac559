"""What every generated function accepts, whatever its target (docs/functions.md).

Each argument is array-like of real numbers, shape (size,) for one state or
(..., size) for many; the leading shapes broadcast together as NumPy's do and
lead the outputs' shapes; arguments go by position or by their documented
names.  NaN, infinity, complex numbers, a scalar for a vector and a wrong last
dimension are ValueErrors naming the argument, and so is a free base's quaternion
(q[3:7]) that is zero: any other is read by its direction.  Written once: the NumPy
target prints `argument` and `leading` into its module (which imports only
numpy and math); the C bindings and the CasADi target call `arguments`.
"""

from __future__ import annotations

import inspect
import math

import numpy as np

__all__ = ["MAXDIMS", "argument", "leading", "given", "arguments", "free_base", "source"]

#: NumPy's limit on the dimensions of an array (32 before NumPy 2).
MAXDIMS = 64


def argument(x, size, name, lead, function, quaternion=False):
    """x as a finite real float array of shape (..., size) with at most `lead`
    leading dimensions (the result's own follow them), or a ValueError naming
    it as an argument of `function`; `quaternion`: x is a free base's q, whose
    quaternion x[..., 3:7] must not be zero, nor |q|² subnormal (a rotation is read from its
    direction, through 2/|q|²)."""
    x = np.asarray(x)
    if x.dtype.kind == "c":
        raise ValueError(f"{function}(): {name} is complex; the dynamics take real numbers")
    try:
        x = np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{function}(): {name} must be real numbers, got {x.dtype} {x.shape}") from None
    if x.ndim == 0 or x.shape[-1] != size:
        raise ValueError(f"{function}(): {name} must have shape (..., {size}), got {x.shape}")
    if x.ndim - 1 > lead:
        raise ValueError(
            f"{function}(): {name} has {x.ndim - 1} leading dimensions, at most {lead} (NumPy "
            f"arrays have at most {MAXDIMS} dimensions, the result's own included)"
        )
    if not (all(map(math.isfinite, x.ravel().tolist())) if x.size <= 64 else np.isfinite(x).all()):
        raise ValueError(f"{function}(): {name} contains NaN or infinity")
    if quaternion:  # |q|² below the smallest normal double: 2/|q|² would overflow
        zero = np.flatnonzero(((x[..., 3:7] ** 2).sum(axis=-1) < 2.2250738585072014e-308).ravel())
        if zero.size:
            index = tuple(int(i) for i in np.unravel_index(zero[0], x.shape[:-1]))
            where = f" (state {index[0] if len(index) == 1 else index})" if index else ""
            raise ValueError(
                f"{function}(): the base's quaternion {name}[3:7] is zero{where} (|q|² below 2.2e-308): a "
                "rotation needs a non-zero quaternion (any other is read by its direction)"
            )
    return x


def leading(function, names, arrays):
    """The leading shape of checked arguments (..., size_i) broadcast together,
    or a ValueError naming the arguments whose leading shapes clash."""
    shape = arrays[0].shape[:-1]
    if any(x.shape[:-1] != shape for x in arrays):
        try:
            shape = np.broadcast_shapes(*(x.shape[:-1] for x in arrays))
        except ValueError:
            shapes = ", ".join(f"{a} {x.shape[:-1]}" for a, x in zip(names, arrays))
            raise ValueError(
                f"{function}(): the leading shapes of the arguments do not broadcast together: {shapes}"
            ) from None
    return shape


def given(function: str, inputs, args: tuple, kwargs: dict) -> dict:
    """{input name: value} of one call, given by position or name; a missing, extra, repeated or
    unknown argument is a TypeError as Python's own.  inputs: ((name, size), …) in order."""
    names = [a for a, _ in inputs]
    if len(args) > len(inputs):
        plural = "s" if len(inputs) != 1 else ""
        raise TypeError(
            f"{function}() takes {len(inputs)} positional argument{plural} but {len(args)} were "
            f"given ({', '.join(names)})"
        )
    values = dict(zip(names, args))
    for key, value in kwargs.items():
        if key not in names:
            raise TypeError(
                f"{function}() got an unexpected keyword argument {key!r} (its arguments are {', '.join(names)})"
            )
        if key in values:
            raise TypeError(f"{function}() got multiple values for argument {key!r}")
        values[key] = value
    missing = [a for a in names if a not in values]
    if missing:
        plural = "s" if len(missing) != 1 else ""
        raise TypeError(
            f"{function}() missing {len(missing)} required positional argument{plural}: "
            + " and ".join(map(repr, missing))
        )
    return values


def arguments(function: str, inputs, args: tuple, kwargs: dict, lead: int, quaternion=None):
    """One call's arguments (`given`), checked and broadcast: (C-contiguous float arrays of shape
    leading + (size,), one per input, leading).

    inputs: ((name, size), …) in order; lead: the most leading dimensions allowed; quaternion:
    the name of the input that is a free base's q (`free_base`), or None.
    """
    names = [a for a, _ in inputs]
    values = given(function, inputs, args, kwargs)
    arrays = [argument(values[a], size, a, lead, function, a == quaternion) for a, size in inputs]
    shape = leading(function, names, arrays)
    return tuple(
        np.ascontiguousarray(np.broadcast_to(x, shape + x.shape[-1:]) if x.shape[:-1] != shape else x) for x in arrays
    ), shape


def free_base(signatures) -> bool:
    """Whether the functions' inputs ((name, ((input, size), …)), …) are a free base's: q has one
    coordinate more than v (its quaternion's four for the three of the body's turn)."""
    sizes = {}
    for _, inputs in signatures:
        sizes.update(inputs)
    velocity = sizes.get("qd", sizes.get("v"))
    return "q" in sizes and velocity is not None and sizes["q"] == velocity + 1


def source() -> str:
    """The text of `argument` and `leading`, for a module that imports only numpy and math."""
    functions = "\n\n".join(inspect.getsource(f) for f in (argument, leading))
    return f"MAXDIMS = {MAXDIMS}\n\n\n{functions.rstrip()}"
