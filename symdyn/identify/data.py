"""Measured motion in: joint angles and torques read, checked and preprocessed for identification.

The data step of identify (excitation → **data** → base regressor → estimate):
`load_data(path)` reads a CSV (header `t, q1…qn, tau1…taun`, optionally
`qd1…qdn`, `qdd1…qddn`, or motor currents `i1…in` with a torque constant
instead of τ; a floating base's columns base_x …, base_vx …, base_dvx …, base_fx … before the
joints') or an NPZ with the same names, and preprocesses it as
practitioners do: a zero-phase Butterworth low-pass on q (`filtfilt`), q̇ and q̈
by central differences of the filtered q where they are not given.  The
decimation of τ and of the regressor Y through one and the same low-pass
filter (Gautier's parallel filtering, `parallel_decimate`) needs Y, so `fit`
applies it with the factor recorded here.  Bad data is a ValueError that
names the file, the column and the row.
"""

from __future__ import annotations

import csv
import os
import re
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from ..derivation.floating import base_columns

if TYPE_CHECKING:
    from ..model import Robot

__all__ = ["Data", "load_data", "from_arrays", "parallel_decimate", "write_csv", "DEFAULT_CUTOFF"]

#: Low-pass cutoff (Hz) of q before differentiation, unless given: well above an excitation's
#: harmonics (a 10 s period with 5 harmonics reaches 0.5 Hz), capped at 0.4 × the sampling rate.
DEFAULT_CUTOFF = 10.0
#: Seconds × cutoff dropped at each end after filtering: filtfilt's edge transients (at 10 Hz, 0.3 s).
EDGE = 3.0
#: Butterworth order of that low-pass (applied forwards and backwards: twice the order, no phase).
ORDER = 4
_KINDS = ("q", "qd", "qdd", "tau", "i")


@dataclass(frozen=True)
class Data:
    """Samples of one motion: t (N,) in s; q, qd, qdd (N, n) in rad (m for prismatic joints),
    rad/s, rad/s²; tau (N, n) in N·m or N.  On a floating base (`base`, its kind) q is (N, nq) and
    qd, qdd, tau (N, nv), the base's columns first (`columns`).  `decimate`: the factor by which `fit` decimates τ
    and Y through the same filter (1: none).  `source` names where the samples came from and
    `notes` what was done to them; `truth` is the arm that simulated data came from."""

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    tau: np.ndarray
    decimate: int = 1
    source: str = "arrays"
    differentiated: bool = False  # q̇ computed from q (then its sign at rest is noise: see fit's rest_speed)
    notes: tuple = field(default=())
    truth: object = field(default=None, compare=False, repr=False)  # the true arm of simulated data
    base: str | None = None  # a floating base's kind: q (N, nq) and qd, qdd, tau (N, nv) start with its columns

    @property
    def n(self) -> int:
        """The number of joints (a floating base's coordinates not counted)."""
        return self.q.shape[1] - (len(base_columns(self.base)["q"]) if self.base else 0)

    def columns(self, kind: str) -> list[str]:
        """The names of q's, qd's, qdd's or tau's columns: a floating base's (`base_columns`), then
        the joints' (q1…qn)."""
        return [*(base_columns(self.base)[kind] if self.base else ()), *(f"{kind}{j + 1}" for j in range(self.n))]

    @property
    def N(self) -> int:
        return self.q.shape[0]

    def check_joints(self, robot: Robot) -> "Data":
        """self, or a ValueError naming the column where the joint count differs from robot's, or
        naming the base joint where the data's differs."""
        if self.base != robot.base_joint:
            raise ValueError(
                f"{self.source}: the data are of a {self.base or 'fixed'} base but the model {robot.name!r} "
                f"has a {robot.base_joint or 'fixed'} base"
            )
        if self.n != robot.n:
            if self.n < robot.n:
                col = f"column q{self.n + 1} is missing"
            else:
                col = f"column q{robot.n + 1} is one too many"
            raise ValueError(
                f"{self.source}: the data have {self.n} joints (q1…q{self.n}) but the model "
                f"{robot.name!r} has {robot.n}: {col}"
            )
        return self


# --------------------------------------------------------------------------- reading


def _read_csv(path: Path) -> tuple[list[str], np.ndarray]:
    """(column names, values (rows, columns)); errors name the line and column."""
    with open(path, newline="") as f:
        reader = csv.reader(f)
        try:
            header = next(reader)
        except StopIteration:
            raise ValueError(f"{path}: the file is empty; expected a header t, q1…qn, tau1…taun") from None
    names = [h.strip().lstrip("#").strip() for h in header]
    if not any(names):
        raise ValueError(f"{path}:1: the header is empty; expected t, q1…qn, tau1…taun")
    for k, name in enumerate(names):
        if names.index(name) != k:
            raise ValueError(f"{path}:1: column {name!r} appears twice in the header")
    try:
        values = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2, dtype=float, comments=None)
    except ValueError:
        values = None
    if values is None or (values.size and values.shape[1] != len(names)):
        _locate_bad_cell(path, names)  # raises with the line and column
    if values.size == 0:
        raise ValueError(f"{path}: no data rows after the header")
    return names, values


def _locate_bad_cell(path: Path, names: list[str]) -> None:
    with open(path, newline="") as f:
        for line, row in enumerate(csv.reader(f), start=1):
            if line == 1 or not row:
                continue
            if len(row) != len(names):
                raise ValueError(
                    f"{path}:{line}: data row {line - 1} has {len(row)} fields, the header "
                    f"{len(names)} ({', '.join(names)})"
                )
            for name, cell in zip(names, row):
                try:
                    float(cell)
                except ValueError:
                    raise ValueError(
                        f"{path}:{line}: data row {line - 1}, column {name}: {cell.strip()!r} is not a number"
                    ) from None
    raise ValueError(f"{path}: cannot be read as comma-separated numbers under one header line")


def _read_npz(path: Path) -> tuple[list[str], np.ndarray]:
    """Columns of an NPZ: one 1-D array per name (t, q1, …), or 2-D arrays q, qd, qdd, tau, i (N, n)."""
    with np.load(path, allow_pickle=False) as npz:
        cols: dict[str, np.ndarray] = {}
        for name in npz.files:
            a = np.asarray(npz[name])
            if a.ndim == 2 and name in _KINDS:
                cols.update((f"{name}{j + 1}", a[:, j]) for j in range(a.shape[1]))
            elif a.ndim == 1:
                cols[name] = a
            else:
                raise ValueError(
                    f"{path}: array {name!r} has shape {a.shape}; expected one column (N,) per "
                    "name, or (N, n) for q, qd, qdd, tau, i"
                )
    lengths = {name: len(a) for name, a in cols.items()}
    if len(set(lengths.values())) > 1:
        N = lengths.get("t", max(lengths.values()))
        odd = next(name for name, length in lengths.items() if length != N)
        raise ValueError(f"{path}: column {odd} has {lengths[odd]} rows, column t {N}")
    try:
        values = np.column_stack([np.asarray(a, dtype=float) for a in cols.values()])
    except (TypeError, ValueError):
        odd = next(name for name, a in cols.items() if not np.issubdtype(np.asarray(a).dtype, np.number))
        raise ValueError(f"{path}: column {odd} is not numeric ({np.asarray(cols[odd]).dtype})") from None
    return list(cols), values


def _joint_columns(names: list[str], kind: str) -> list[str]:
    """kind1, kind2, … as found (kind "q" does not take "qd1")."""
    found = sorted((int(m.group(1)), name) for name in names if (m := re.fullmatch(rf"{kind}(\d+)", name)))
    return [name for _, name in found]


def load_data(
    path: str | os.PathLike[str],
    *,
    joints: Robot | int | None = None,
    torque_constant: ArrayLike | None = None,
    cutoff: float | None = None,
    order: int = ORDER,
    decimate: int = 1,
) -> Data:
    """Read and preprocess measured motion from a CSV or NPZ file (see the module docstring).

    joints: the model (a Robot) or its joint count, checked against the file's; a Robot on a floating
    base also reads its base's columns base_x …, base_vx …, base_dvx …, base_fx … (`floating.base_columns`:
    its pose, body-frame velocity and acceleration, the force and moment on it).  torque_constant:
    a number or one per joint (N·m/A): τ = K·i from the currents i1…in instead of tau columns.
    cutoff: the low-pass cutoff in Hz of q (and of qd, qdd where given) before differentiation
    (default: `DEFAULT_CUTOFF` where q̇ or q̈ must be computed, else no filtering).  decimate: the
    factor of Gautier's parallel decimation of τ and Y, applied by `fit`.

    Returns:
        The `Data`: t, q, qd, qdd, tau, with `notes` saying what was done to them.

    Raises:
        ValueError: no such file (or a folder); a file that cannot be read as numbers
            under one header (empty, a duplicate column, a row of another length, a
            cell that is not a number, an NPZ array of the wrong shape), the message
            naming line and column; no t, no q1…qn, a missing or extra joint
            column, no tau1…taun (or currents without a torque constant, or a torque
            constant without currents or of the wrong length); a joint count other
            than `joints`'; a floating base's column missing, or one without a
            floating-base model; a NaN or infinite value; fewer than 2 rows, time that
            does not increase, non-uniform sampling where filtering,
            differentiation or decimation needs it; a cutoff outside (0, Nyquist);
            too few samples to filter; decimate not a positive integer.
        OSError: the file cannot be opened.
    """
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"no data file {path}" + (": it is a folder" if path.is_dir() else ""))
    names, values = (_read_npz if path.suffix.lower() == ".npz" else _read_csv)(path)
    return _from_columns(
        dict(zip(names, values.T)),
        source=str(path),
        joints=joints,
        torque_constant=torque_constant,
        cutoff=cutoff,
        order=order,
        decimate=decimate,
        first_line=1 if path.suffix.lower() != ".npz" else None,
    )


def from_arrays(
    t,
    q,
    tau=None,
    *,
    qd=None,
    qdd=None,
    current=None,
    torque_constant=None,
    joints=None,
    cutoff: float | None = None,
    order: int = ORDER,
    decimate: int = 1,
    source: str = "arrays",
) -> Data:
    """`load_data` for arrays in memory: t (N,), q (N, n) and tau (N, n) (or currents with a torque
    constant), qd and qdd (N, n) optional.  joints a Robot on a floating base: q (N, nq), qd, qdd and
    tau (N, nv), the base's columns first (its velocities and accelerations required).

    Raises:
        ValueError: as `load_data`, and arrays too narrow for a floating base's columns.
    """
    cols = {"t": np.asarray(t, dtype=float)}
    floating = getattr(joints, "base_joint", None)
    base = base_columns(floating) if floating else {}
    for kind, a in (("q", q), ("qd", qd), ("qdd", qdd), ("tau", tau), ("i", current)):
        if a is not None:
            a = np.asarray(a, dtype=float)
            a = a[:, None] if a.ndim == 1 else a
            named = base.get(kind, ())  # a floating base's columns come first
            if a.ndim != 2 or a.shape[1] < len(named):
                raise ValueError(f"{source}: {kind} of shape {a.shape} has no room for the base's {', '.join(named)}")
            cols.update(zip(named, a.T))
            cols.update((f"{kind}{j + 1}", a[:, len(named) + j]) for j in range(a.shape[1] - len(named)))
    return _from_columns(
        cols,
        source=source,
        joints=joints,
        torque_constant=torque_constant,
        cutoff=cutoff,
        order=order,
        decimate=decimate,
        first_line=None,
    )


def _where(source: str, first_line: int | None, row: int) -> str:
    """'file:LINE: row ROW' for a CSV (1-based data rows, the header on line 1), else 'source: row ROW'."""
    if first_line is None:
        return f"{source}: row {row}"
    return f"{source}:{row + first_line}: row {row}"


def _from_columns(cols: dict, *, source: str, joints, torque_constant, cutoff, order, decimate, first_line) -> Data:
    names = list(cols)
    if "t" not in cols:
        raise ValueError(f"{source}: no column 't' (time in s); the columns are {', '.join(names)}")
    qs = _joint_columns(names, "q")
    lone = getattr(joints, "base_joint", None) is not None and getattr(joints, "n", None) == 0  # a drone
    if not qs and not lone:
        raise ValueError(f"{source}: no joint angle columns q1…qn; the columns are {', '.join(names)}")
    n = len(qs)
    for kind in ("q", "qd", "qdd", "tau", "i"):
        present = _joint_columns(names, kind)
        for j in range(1, max(n, len(present)) + 1):
            if present and f"{kind}{j}" not in cols:
                raise ValueError(
                    f"{source}: column {kind}{j} is missing (found {', '.join(present)}; q1…q{n} give {n} joints)"
                )
        if len(present) > n:
            raise ValueError(f"{source}: column {kind}{n + 1} is one too many: q1…q{n} give {n} joints")
    if joints is not None:
        expected = joints if isinstance(joints, int) else joints.n
        if n != expected:
            label = f"the model {joints.name!r}" if not isinstance(joints, int) else "the model"
            col = f"column q{n + 1} is missing" if n < expected else f"column q{expected + 1} is one too many"
            raise ValueError(f"{source}: the data have {n} joints (q1…q{n}) but {label} has {expected}: {col}")
    kind = getattr(joints, "base_joint", None)
    base = base_columns(kind) if kind else {}
    expected = [c for k in ("q", "qd", "qdd", "tau") for c in base.get(k, ())]
    stray = [c for c in names if c.startswith("base_") and c not in expected]
    if stray:
        raise ValueError(
            f"{source}: column {stray[0]} describes a floating base "
            + (
                f"but is not one of the {kind} base's columns ({', '.join(expected)})"
                if kind
                else "but the data are read without a floating-base model (give joints=the Robot)"
            )
        )
    for c in expected:
        if c not in cols:
            raise ValueError(
                f"{source}: column {c} is missing: a {kind} base's data give its coordinates, velocities "
                f"and accelerations (its frame) and the force and moment on it ({', '.join(expected)})"
            )
    if torque_constant is not None:
        if "i1" not in cols:
            raise ValueError(
                f"{source}: a torque constant was given but there is no column i1 (motor currents i1…i{n})"
            )
        K = (
            np.broadcast_to(np.asarray(torque_constant, dtype=float), (n,))
            if np.ndim(torque_constant) == 0
            else np.asarray(torque_constant, dtype=float)
        )
        if K.shape != (n,) or not np.all(np.isfinite(K)):
            raise ValueError(f"torque constant: expected one number or {n} (one per joint), got {torque_constant!r}")
        tau_cols = [f"i{j + 1}" for j in range(n)]
    elif n == 0:  # a lone body: its base's wrench is all there is
        K, tau_cols = np.ones(0), []
    else:
        if "tau1" not in cols:
            extra = " (or motor currents i1…: give their torque constant)" if "i1" in cols else ""
            raise ValueError(f"{source}: column tau1 is missing: the joint torques tau1…tau{n}{extra}")
        K, tau_cols = np.ones(n), [f"tau{j + 1}" for j in range(n)]
    used = ["t", *qs] + [f"{k}{j + 1}" for k in ("qd", "qdd") if f"{k}1" in cols for j in range(n)] + tau_cols
    used += expected
    for name in used:  # the first NaN or infinity, by row
        bad = np.flatnonzero(~np.isfinite(cols[name]))
        if bad.size:
            raise ValueError(
                f"{_where(source, first_line, int(bad[0]) + 1)}, column {name}: "
                f"{cols[name][bad[0]]} (every value must be a finite number)"
            )
    t = np.asarray(cols["t"], dtype=float)
    if len(t) < 2:
        raise ValueError(f"{source}: {len(t)} row(s); identification needs many samples")
    dt = np.diff(t)
    if np.any(dt <= 0):
        k = int(np.flatnonzero(dt <= 0)[0]) + 2
        raise ValueError(
            f"{_where(source, first_line, k)}, column t: time {t[k - 1]!r} does not come after "
            f"the previous row's {t[k - 2]!r} (time must increase)"
        )
    stack = lambda names: np.column_stack([cols[c] for c in names]).astype(float) if names else np.zeros((len(t), 0))  # noqa: E731
    q = stack([f"q{j + 1}" for j in range(n)])
    qd = stack([f"qd{j + 1}" for j in range(n)]) if "qd1" in cols or lone else None
    qdd = stack([f"qdd{j + 1}" for j in range(n)]) if "qdd1" in cols or lone else None
    tau = stack(tau_cols) * K
    # a floating base: its pose, velocity, acceleration and wrench as given (a quaternion is not low-passed)
    bq, bv, ba, bf = (np.column_stack([cols[c] for c in base[k]]).astype(float) for k in base) if kind else [None] * 4
    notes = [f"{len(t)} samples of {n} joints{f' on a {kind} base' if kind else ''} from {source}"]
    if torque_constant is not None:
        notes.append(f"tau = K·i with K = {K.tolist()}")
    if not isinstance(decimate, (int, np.integer)) or decimate < 1:
        raise ValueError(f"decimate must be a positive integer, got {decimate!r}")
    needs_derivative = qd is None or qdd is None
    differentiated = qd is None
    if cutoff is not None or needs_derivative or decimate > 1:
        rate = _uniform_rate(t, source, first_line)
    if cutoff is not None or needs_derivative:
        cutoff = min(DEFAULT_CUTOFF, 0.4 * rate) if cutoff is None else float(cutoff)
        if not 0 < cutoff < rate / 2:
            raise ValueError(
                f"cutoff {cutoff} Hz: it must lie between 0 and the Nyquist frequency {rate / 2:g} Hz "
                f"of data sampled at {rate:g} Hz"
            )
        q, qd, qdd = (lowpass(x, cutoff, rate, order) if x is not None else None for x in (q, qd, qdd))
        notes.append(
            f"q{', given qd/qdd' if not needs_derivative else ''} low-passed: Butterworth order {order}, "
            f"{cutoff:g} Hz, zero phase (filtfilt) at {rate:g} Hz"
        )
        if kind:
            bv, ba = lowpass(bv, cutoff, rate, order), lowpass(ba, cutoff, rate, order)
            notes.append("the base's velocities and accelerations low-passed alike, its coordinates as given")
        if qd is None:
            qd = np.gradient(q, t, axis=0, edge_order=2)
            notes.append("qd by central differences of the filtered q")
        if qdd is None:
            qdd = np.gradient(qd, t, axis=0, edge_order=2)
            notes.append("qdd by central differences of qd")
        edge = int(np.ceil(EDGE / cutoff * rate))
        if len(t) <= 2 * edge + 1:
            raise ValueError(
                f"{source}: {len(t)} samples are too few to filter at {cutoff:g} Hz: the first and last "
                f"{edge} carry the filter's edge transients"
            )
        keep = slice(edge, len(t) - edge)
        t, q, qd, qdd, tau = t[keep], q[keep], qd[keep], qdd[keep], tau[keep]
        if kind:
            bq, bv, ba, bf = bq[keep], bv[keep], ba[keep], bf[keep]
        notes.append(f"the first and last {edge} samples dropped ({EDGE:g}/cutoff: the filter's edge transients)")
    if decimate > 1:
        notes.append(f"tau and Y decimated by {decimate} through one filter (parallel filtering) in fit")
    if kind:  # the base's columns first, as every function of the model takes them
        q, qd, qdd, tau = np.hstack([bq, q]), np.hstack([bv, qd]), np.hstack([ba, qdd]), np.hstack([bf, tau])
    return Data(
        t=t,
        q=q,
        qd=qd,
        qdd=qdd,
        tau=tau,
        decimate=int(decimate),
        source=source,
        notes=tuple(notes),
        differentiated=differentiated,
        base=kind,
    )


def _uniform_rate(t: np.ndarray, source: str, first_line) -> float:
    """The sampling rate (Hz); a ValueError naming the row where the sampling is not uniform."""
    dt = np.diff(t)
    step = float(np.median(dt))
    off = np.abs(dt - step) > 1e-3 * step
    if off.any():
        k = int(np.flatnonzero(off)[0]) + 2
        raise ValueError(
            f"{_where(source, first_line, k)}, column t: the time step {dt[k - 2]:g} s differs from "
            f"the median step {step:g} s; filtering, differentiation and decimation need uniformly "
            "sampled data (resample it, or give qd and qdd)"
        )
    return 1.0 / step


def lowpass(x: np.ndarray, cutoff: float, rate: float, order: int = ORDER) -> np.ndarray:
    """x (N, …) low-passed along time: Butterworth of `order` at `cutoff` Hz, forwards and backwards."""
    from scipy.signal import butter, filtfilt

    b, a = butter(order, cutoff / (rate / 2))
    if len(x) <= 3 * max(len(a), len(b)):
        raise ValueError(f"{len(x)} samples are too few to filter (filtfilt pads {3 * max(len(a), len(b))})")
    return filtfilt(b, a, x, axis=0)


def _stages(factor: int) -> list[int]:
    """factor as a product of stages of at most 13 (scipy's advice for one IIR decimation)."""
    stages, rest = [], factor
    while rest > 1:
        d = next((d for d in range(13, 1, -1) if rest % d == 0), None)
        if d is None:
            raise ValueError(
                f"decimate {factor}: it has a prime factor {rest} above 13; choose a factor "
                "whose prime factors are at most 13 (e.g. 10, 12, 20)"
            )
        stages.append(d)
        rest //= d
    return stages


def parallel_decimate(Y: np.ndarray, tau: np.ndarray, factor: int, t: np.ndarray | None = None):
    """Gautier's parallel filtering: τ (N, n) and every column of Y (N, n, p) low-passed by the same
    zero-phase filter (Chebyshev I, order 8, cutoff 0.8 × the new Nyquist frequency; scipy's
    `decimate`) and kept at every `factor`-th sample.  The filter is linear, so Y·β = τ still holds
    for the filtered pair; the noise above the dynamics' band is removed from both alike.
    Returns (Y, tau, t) decimated."""
    from scipy.signal import decimate

    for d in _stages(factor):
        Y = decimate(Y, d, ftype="iir", axis=0, zero_phase=True)
        tau = decimate(tau, d, ftype="iir", axis=0, zero_phase=True)
        t = t[::d] if t is not None else None
    return Y, tau, t


# --------------------------------------------------------------------------- writing


def write_csv(path, data: Data, *, derivatives: bool = True) -> Path:
    """Write `data` as CSV: t, q1…qn, (qd1…qdn, qdd1…qddn when `derivatives`), tau1…taun; a floating
    base's columns before the joints' of each kind (its velocities and accelerations always)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    kinds = ("q", "qd", "qdd", "tau") if derivatives or data.base else ("q", "tau")
    header = ["t"] + [c for k in kinds for c in data.columns(k)]
    values = np.column_stack([data.t] + [getattr(data, k) for k in kinds])
    if data.base and not derivatives:  # the base's velocities and accelerations stay (never differentiated)
        keep = [c for c in header if not c.startswith(("qd", "qdd"))]
        values, header = values[:, [header.index(c) for c in keep]], keep
    np.savetxt(path, values, delimiter=",", header=",".join(header), comments="", fmt="%.17g")
    return path


def with_tau(data: Data, tau: np.ndarray, note: str) -> Data:
    """data with other torques (the same shape)."""
    return replace(data, tau=np.asarray(tau, dtype=float), notes=data.notes + (note,))
