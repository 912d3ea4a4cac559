"""The lazy C target under threads and fork (issue 44, defect 7): concurrent first calls from
threads agree; a child forked while the background derivation holds its lock calls a function
and finishes (its locks are its own); a derivation that fails on the background thread is
raised by the first call that needs it, not derived a second time."""

import os
import threading
import time

import numpy as np
import pytest

import symdyn
from symdyn.model.random_arms import ArmOptions, random_arm
from symdyn.numeric import reference as ref

ARM = dict(seed=21, options=ArmOptions(n_min=3, n_max=3, symbolic=0))


def _arm():
    return random_arm(ARM["seed"], ARM["options"])


def test_concurrent_first_calls_from_threads_agree(tmp_path, monkeypatch):
    monkeypatch.setenv("SYMDYN_CACHE_DIR", str(tmp_path))
    robot = _arm()
    model = symdyn.load(robot, "c")
    z = np.full(robot.n, 0.3)
    results, errors = [None] * 6, []

    def call(k):
        try:
            results[k] = (model.tau(z, z, z), model.M(z)) if k % 2 else (model.M(z), model.tau(z, z, z))[::-1]
        except BaseException as exc:  # noqa: BLE001 - reported below
            errors.append(exc)

    threads = [threading.Thread(target=call, args=(k,)) for k in range(6)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(300)
    assert not errors, errors
    want = ref.rne(robot, z, z, z)
    for tau, M in results:
        np.testing.assert_allclose(tau, want, atol=1e-10)
        np.testing.assert_allclose(M, ref.inertia(robot, z), atol=1e-10)


@pytest.mark.skipif(not hasattr(os, "fork"), reason="fork is POSIX's")
def test_a_child_forked_during_the_background_derivation_calls_and_finishes(tmp_path, monkeypatch):
    monkeypatch.setenv("SYMDYN_CACHE_DIR", str(tmp_path))
    robot = _arm()
    model = symdyn.load(robot, "c")  # the derivation starts on a thread of its own, holding its lock
    time.sleep(0.05)
    z = np.full(robot.n, 0.2)
    want = ref.rne(robot, z, z, z)
    pid = os.fork()
    if pid == 0:  # the child: no pytest from here on
        import faulthandler
        import sys

        faulthandler.dump_traceback_later(60, exit=True, file=sys.stderr)  # where a child hangs, shown
        code = 1
        try:
            code = 0 if np.allclose(model.tau(z, z, z), want, atol=1e-10) else 3
        finally:
            os._exit(code)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            break
        time.sleep(0.1)
    else:
        os.kill(pid, 9)
        os.waitpid(pid, 0)
        pytest.fail("the forked child did not finish its first call: a lock held across the fork")
    assert os.WIFEXITED(status) and os.WEXITSTATUS(status) == 0, status
    np.testing.assert_allclose(model.tau(z, z, z), want, atol=1e-10)  # and the parent still works


def test_a_background_derivation_failure_is_raised_by_the_first_call(tmp_path, monkeypatch):
    monkeypatch.setenv("SYMDYN_CACHE_DIR", str(tmp_path))
    from symdyn.codegen import choice

    calls = []

    def broken(robot):
        calls.append(robot.name)
        raise ValueError("the derivation broke (a test)")

    monkeypatch.setattr(choice, "derivations", broken)
    robot = _arm()
    model = symdyn.load(robot, "c")
    z = np.zeros(robot.n)
    for _ in range(2):
        with pytest.raises(ValueError, match="the derivation broke"):
            model.tau(z, z, z)
    assert calls == [robot.name]  # derived once, on the background thread; raised, not re-derived


@pytest.mark.skipif(not hasattr(os, "fork"), reason="fork is POSIX's")
def test_a_fork_waits_while_a_lock_file_is_being_opened_or_closed():
    """A thread between opening a build lock's file and registering it (or unregistering and
    closing it) holds `_HELD_LOCK`: a fork then waits, so the child never inherits a lock file it
    does not know to close; the child gets a free lock of its own."""
    from symdyn.derivation import cache

    inside, release = threading.Event(), threading.Event()

    def opening() -> None:
        with cache._HELD_LOCK:
            inside.set()
            release.wait(5)

    thread = threading.Thread(target=opening)
    thread.start()
    inside.wait(5)
    threading.Timer(0.3, release.set).start()
    start = time.monotonic()
    pid = os.fork()
    if pid == 0:
        os._exit(0 if cache._HELD_LOCK.acquire(timeout=1) else 4)
    waited = time.monotonic() - start
    _, status = os.waitpid(pid, 0)
    thread.join(5)
    assert waited >= 0.25, waited
    assert os.WIFEXITED(status) and os.WEXITSTATUS(status) == 0, status
    assert cache._HELD_LOCK.acquire(timeout=1)  # the parent's is free again after the fork
    cache._HELD_LOCK.release()
