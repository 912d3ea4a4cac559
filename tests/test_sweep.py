"""Sweeps on a real Dask cluster (`symdyn.sweep`): a LocalCluster of 2 worker processes,
started once for this file, runs small sweeps of the two-link arm's minimum-time
motions (N = 8, no re-simulation: a few tens of ms each) and must give exactly the
rows of a serial run in this process — also when a task raises, when a worker is
killed mid-sweep, and when a sweep is interrupted and resumed.  The Monte-Carlo
sweep's nominal draw reproduces the chapter study's computed-torque row."""

from __future__ import annotations

import csv
import functools
import os
import re
import signal
import socket
import subprocess
import sys
import time

import distributed  # the sweep extra, part of the test extra: pip install -e '.[test]'
import numpy as np
import pytest

from symdyn import cli
from symdyn.numeric import reference as ref
from symdyn.sweep import engine, library, montecarlo
from symdyn.sweep.table import decode_json

#: Eight motions of the two-link arm, coarse grid, no open-loop check: cheap, real solves.
INPUTS = library.inputs(8, arm="twolink", N=8, verify=False)


def results(rows) -> dict[str, dict[str, str]]:
    """Rows keyed by task id, without the columns that describe the run (worker, wall time)."""
    out = {r["task_id"]: {k: v for k, v in r.items() if k not in engine.META or k == "error"} for r in rows}
    assert len(out) == len(rows), "a task id appears twice"
    return out


# The tests without the cluster come first: while a LocalCluster's scheduler thread lives in this
# process, thousands of small calls into compiled code wait on the GIL it keeps taking.


def test_monte_carlo_models_each_draw_exactly_and_reproduces_the_chapter_study():
    """Draws 0 (nominal) and masses and inertias x 1.1 and x 0.9 (COMs and friction kept) are the
    controller models of the study's computed-torque rows (`torque_control`, quick: T = 1 s):
    the same closed loops, simulated here as the study does (one batch of the three models)."""
    from symdyn.apps import control as C
    from symdyn.apps.studies import control as study

    draws = montecarlo.inputs(2, arm="puma560", T=1.0)
    robot = montecarlo.scene("puma560")[0]
    q, qd, qdd = np.random.default_rng(3).normal(size=(3, 6))
    wrong = montecarlo.controller_model("puma560", draws[1]["draw"])
    assert np.allclose(
        wrong.tau(q, qd, qdd), ref.rne(montecarlo.perturbed(robot, draws[1]["draw"]), q, qd, qdd), rtol=0, atol=1e-10
    )

    puma, plant = study.puma_scene()
    factors = np.array([1.0, 1.1, 0.9])
    traj = functools.partial(C.quintic, puma.qz, puma.qr, 1.0)
    ct = C.ComputedTorque(C.scaled(plant, puma, factors), traj, 100.0, 20.0)
    tr = C.simulate(
        lambda t, q, qd, tau: plant.fdyn(q, qd, tau), ct, 1.5, np.tile(puma.qz, (3, 1)), dt=1e-3, period=1e-3
    )
    rows = np.abs(traj(tr.t)[0][:, None, :] - tr.q).max(0)  # (3 models, 6 joints)
    for f, expected in zip(factors, rows):
        item = dict(draws[0], draw={"m": [f] * 6, "r": [[1.0] * 3] * 6, "I": [f] * 6, "B": [1.0] * 6})
        got = montecarlo.tracking(item)
        assert np.allclose(got["joint_max_error"], expected, rtol=1e-8, atol=1e-12), (f, got, expected)
    assert rows[0].max() == pytest.approx(0.320e-3, abs=1e-6)  # the study's 0.320 mrad at T = 1 s


def test_the_command_lists_runs_and_checks_its_options(tmp_path, capsys):
    assert cli.main(["sweep", "--list"]) == 0
    listed = capsys.readouterr().out
    assert "trajectory-library" in listed and "monte-carlo" in listed
    assert cli.main(["sweep", "monte-carlo", "--N", "10", "--out", str(tmp_path)]) == 2
    assert "--N does not apply to the monte-carlo sweep" in capsys.readouterr().err
    assert (
        cli.main(
            [
                "sweep",
                "monte-carlo",
                "--arm",
                "twolink",
                "--n",
                "2",
                "--T",
                "0.2",
                "--workers",
                "0",
                "--no-progress",
                "--out",
                str(tmp_path),
            ]
        )
        == 0
    )
    out = capsys.readouterr().out
    assert "2 of 2 tasks" in out and (tmp_path / "montecarlo_error.png").is_file()


def test_library_motions_are_re_simulated_with_the_reference(tmp_path):
    """verify=True: each motion's torque re-simulated with the reference reaches its goal with every
    limit held, and the summary says so; the Panda's scene is its URDF's limits (Franka's data sheet:
    87 / 12 N·m, 2.175 / 2.61 rad/s) and its motions are checked interval by interval."""
    items = library.inputs(2, arm="twolink")  # N = 40; at 20 the first misses its goal by 0.47 rad
    outcome = engine.run(library.SWEEP, items, tmp_path, workers=0, progress=False)
    for row in outcome.rows:
        assert row["check"] == "1" and float(row["goal_error"]) < 1e-2 and float(row["limit_violation"]) <= 1e-6
    assert "re-simulated open loop with the reference: 2 of 2 reach the goal" in (tmp_path / "summary.txt").read_text()
    _, limits = library.scene("panda")
    assert np.array_equal(limits.tau, [87, 87, 87, 87, 12, 12, 12])
    assert np.array_equal(limits.qd, [2.175] * 4 + [2.61] * 3)
    assert library.REPLAY["panda"] == "intervals" and library.inputs(1, arm="panda")[0]["N"] == 60


def _echo(item: dict) -> dict:
    return {"value": item["index"] * 2, "index": -1} if item["index"] == 1 else {"value": item["index"] * 2}


def test_a_result_never_shares_or_overwrites_an_input_cell(tmp_path):
    """A column named both as input and result is refused when the sweep is made (one CSV cell for
    two values shifted every later cell of a row); a task that returns a key outside its result
    columns (here the input's own index) is that task's error, and its input is kept."""
    with pytest.raises(ValueError, match=r"column\(s\) \['stages'\] named more than once"):
        engine.Sweep("s", "", _echo, None, ("index", "stages"), ("stages", "bad"))
    with pytest.raises(ValueError, match=r"\['wall_s'\] are the table's own"):
        engine.Sweep("s", "", _echo, None, ("index",), ("wall_s",))
    sweep = engine.Sweep("echo", "", _echo, None, ("index",), ("value",))
    outcome = engine.run(sweep, [{"index": k} for k in range(3)], tmp_path, workers=0, progress=False)
    rows = {int(r["index"]): r for r in outcome.rows}
    assert [rows[k]["value"] for k in (0, 2)] == ["0", "4"] and not rows[0]["error"]
    assert rows[1]["value"] == "" and "returned ['index']" in rows[1]["error"]
    again = list(csv.DictReader((tmp_path / "results.csv").open()))
    assert {int(r["index"]): r for r in again} == rows


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_an_unreachable_scheduler_fails_within_seconds_naming_it(tmp_path, monkeypatch, capsys):
    address = f"tcp://127.0.0.1:{_free_port()}"
    start = time.perf_counter()
    with pytest.raises(engine.SchedulerUnreachable, match=f"no Dask scheduler answers at {re.escape(address)}"):
        engine.run(library.SWEEP, INPUTS[:1], tmp_path / "a", scheduler=address, progress=False)
    assert time.perf_counter() - start < 5
    monkeypatch.setenv("DASK_SCHEDULER_ADDRESS", address)
    code = cli.main(["sweep", "trajectory-library", "--arm", "twolink", "--n", "1", "--out", str(tmp_path / "b")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and err[0].startswith(f"symdyn: error: no Dask scheduler answers at {address}")


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None, silence_logs=50
    )
    with distributed.Client(cluster) as c:
        yield c
    cluster.close()


@pytest.fixture(scope="module")
def serial(tmp_path_factory):
    """The reference: the same tasks run one after the other in this process."""
    outcome = engine.run(library.SWEEP, INPUTS, tmp_path_factory.mktemp("serial"), workers=0, progress=False)
    return results(outcome.rows)


def test_the_serial_run_solves_every_motion(serial):
    assert len(serial) == len(INPUTS)
    for row in serial.values():
        assert row["error"] == "" and row["status"] == "Solve_Succeeded", row
        T, q = float(row["T"]), np.array(decode_json(row["q"]))
        assert 0.05 < T < 5.0 and q.shape == (9, 2)
        assert np.allclose(q[0], decode_json(row["start"]), atol=1e-9)
        assert np.allclose(q[-1], decode_json(row["goal"]), atol=1e-6)
        assert float(row["limit_violation"]) <= 1e-6


def test_a_sweep_on_two_worker_processes_equals_a_serial_run_exactly(client, serial, tmp_path):
    outcome = engine.run(library.SWEEP, INPUTS, tmp_path, client=client, progress=False)
    assert results(outcome.rows) == serial
    workers = {r["worker"] for r in outcome.rows}
    assert workers and all(not w.endswith(f":{os.getpid()}") for w in workers), workers
    lines = (tmp_path / "results.csv").read_text().splitlines()
    assert len(lines) == 1 + len(INPUTS)
    assert "8 of 8 tasks" in (tmp_path / "summary.txt").read_text()


def test_a_task_that_raises_is_recorded_with_its_input(client, serial, tmp_path):
    bad = dict(INPUTS[0], index=99, start=[float("nan"), 0.0])
    outcome = engine.run(library.SWEEP, INPUTS[:2] + [bad], tmp_path, client=client, progress=False)
    got = results(outcome.rows)
    failed = got.pop(engine.task_id(bad))
    assert re.match(
        r"ValueError: start pose must be 2 finite joint angles for twolink, got \[nan, 0\.0\]", failed["error"]
    ), failed["error"]
    assert failed["start"] == "[NaN,0.0]" and failed["index"] == "99" and failed["T"] == ""
    assert got == {k: serial[k] for k in got} and len(got) == 2
    assert outcome.errors == 1 and "1 row(s) record an error" in (tmp_path / "summary.txt").read_text()


def test_resume_after_an_interruption_gives_identical_results(client, serial, tmp_path):
    def interrupt_after_three(row, seen=[]):
        seen.append(row["task_id"])
        if len(seen) == 3:
            raise KeyboardInterrupt

    with pytest.raises(engine.SweepInterrupted, match="3 of 8 results are on disk"):
        engine.run(library.SWEEP, INPUTS, tmp_path, client=client, progress=False, on_row=interrupt_after_three)
    table = tmp_path / "results.csv"
    assert len(table.read_text().splitlines()) == 4
    assert "interrupted" in (tmp_path / "summary.txt").read_text()
    with table.open("a") as fh:  # a kill in the middle of writing a row
        fh.write('000007-deadbeef00,7,twolink,0,8,0,"[0.1')
    with pytest.raises(ValueError, match="already holds results: pass --resume"):
        engine.run(library.SWEEP, INPUTS, tmp_path, client=client, progress=False)
    outcome = engine.run(library.SWEEP, INPUTS, tmp_path, client=client, progress=False, resume=True)
    assert outcome.ran == 5
    assert results(outcome.rows) == serial
    assert len(table.read_text().splitlines()) == 1 + len(INPUTS)
    again = engine.run(library.SWEEP, INPUTS, tmp_path, client=client, progress=False, resume=True)
    assert again.ran == 0 and results(again.rows) == serial
    with pytest.raises(ValueError, match=r"result\(s\) of other inputs"):
        engine.run(library.SWEEP, INPUTS[:4], tmp_path, client=client, progress=False, resume=True)


def test_a_worker_killed_mid_sweep_loses_and_duplicates_nothing(client, serial, tmp_path):
    killed = {}

    def kill_one(row):
        if killed:
            return
        busy = {addr: keys for addr, keys in client.processing().items() if keys}
        addr = next(iter(busy))
        pid = client.run(os.getpid, workers=[addr])[addr]
        killed.update(pid=pid, tasks=len(busy[addr]))
        os.kill(pid, signal.SIGKILL)

    outcome = engine.run(library.SWEEP, INPUTS, tmp_path, client=client, progress=False, on_row=kill_one)
    assert killed["tasks"] >= 1, "the killed worker had no task in hand"
    assert results(outcome.rows) == serial
    assert len((tmp_path / "results.csv").read_text().splitlines()) == 1 + len(INPUTS)
    assert all(not r["worker"].endswith(f":{killed['pid']}") or r["warm"] for r in outcome.rows)


def test_a_task_id_needs_an_integer_index():
    """int(3.7) would silently make task 3, and int("x")'s error named no input."""
    assert engine.task_id({"index": 7, "s": 1}).startswith("000007-")
    assert engine.task_id({"index": np.int64(7), "s": 1}) == engine.task_id({"index": 7, "s": 1})
    for index in (3.7, "x", "3", True, None):
        with pytest.raises(
            TypeError, match=rf"a sweep input's index must be an integer, got \w+ {re.escape(repr(index))}"
        ):
            engine.task_id({"index": index, "s": 1})


# make test-all: a sweep on worker processes is in the main suite on a LocalCluster
# (test_a_sweep_on_two_worker_processes_equals_a_serial_run_exactly), the command's --scheduler
# address in test_an_unreachable_scheduler_fails_within_seconds_naming_it
@pytest.mark.slow
def test_the_command_runs_on_a_cluster_started_apart_given_by_its_address(serial, tmp_path, capsys):
    """`--scheduler tcp://…`: a scheduler and a worker started as their own processes with Dask's
    command-line tools, as on a real cluster; the rows equal the serial run's."""
    address = f"tcp://127.0.0.1:{_free_port()}"
    scheduler = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "distributed.cli.dask_scheduler",
            "--host",
            "127.0.0.1",
            "--port",
            address.rsplit(":", 1)[1],
            "--dashboard-address",
            ":0",
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    worker = subprocess.Popen(
        [sys.executable, "-m", "distributed.cli.dask_worker", address, "--nthreads", "1", "--no-dashboard"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        deadline = time.perf_counter() + 60
        while True:
            try:
                with distributed.Client(address, timeout=5) as c:
                    c.wait_for_workers(1, timeout=60)
                break
            except OSError:
                assert time.perf_counter() < deadline, "the scheduler did not start"
                time.sleep(0.2)
        argv = ["sweep", "trajectory-library", "--arm", "twolink", "--n", "2", "--N", "8", "--no-verify"]
        assert cli.main([*argv, "--scheduler", address, "--no-progress", "--out", str(tmp_path)]) == 0
        assert f"Dask scheduler {address}" in capsys.readouterr().out
        rows = list(csv.DictReader((tmp_path / "results.csv").open()))
        assert results(rows) == {tid: serial[tid] for tid in results(rows)} and len(rows) == 2
        assert {tid for tid in results(rows)} == {engine.task_id(item) for item in INPUTS[:2]}
    finally:
        for proc in (worker, scheduler):
            proc.terminate()
            proc.wait(timeout=30)
