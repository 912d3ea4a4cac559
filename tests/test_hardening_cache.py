"""The caches are an optimisation: a corrupt entry is rebuilt, never trusted,
and an unwritable cache folder is warned about once and done without."""

import os
import subprocess
import sys
import time

import numpy as np

from symdyn.derivation import cache


def test_a_cache_entry_with_any_flipped_bit_is_rebuilt_or_exactly_right(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("SYMDYN_CACHE_DIR", str(tmp_path))
    value = {"M": [[1.0 + 2**-40, 0.25], [0.25, 3.0]], "names": ("q1", "q2")}
    cache.cached("test", "k" * 64, lambda: value)
    (path,) = tmp_path.glob("test-*.pickle")
    good = path.read_bytes()
    positions = np.linspace(0, len(good) - 1, 80).astype(int)
    for position in positions:
        bad = bytearray(good)
        bad[position] ^= 1 << (position % 8)
        path.write_bytes(bytes(bad))
        got, hit = cache.cached("test", "k" * 64, lambda: "rebuilt")
        assert got == ("rebuilt" if not hit else value), f"bit flip at byte {position} gave {got!r}"
        assert not hit, f"bit flip at byte {position} went unnoticed"
        assert "ignored" in capsys.readouterr().err
    path.write_bytes(good)
    assert cache.cached("test", "k" * 64, lambda: "rebuilt") == (value, True)


def test_a_truncated_cache_entry_is_rebuilt(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("SYMDYN_CACHE_DIR", str(tmp_path))
    cache.cached("test", "k" * 64, lambda: [1.0, 2.0])
    (path,) = tmp_path.glob("test-*.pickle")
    path.write_bytes(path.read_bytes()[:-5])
    assert cache.cached("test", "k" * 64, lambda: "rebuilt") == ("rebuilt", False)
    assert "ignored" in capsys.readouterr().err


_UNWRITABLE = """
import dataclasses, sys
import numpy as np
import symdyn
from symdyn import models
from symdyn.numeric import reference as ref

twolink = models.load("twolink")
dyn = symdyn.derive(twolink)
print("derive", dyn.M.shape)
heavy = dataclasses.replace(twolink.payload(2.5, (0.1, 0, 0)), name="heavy")
q = np.array([[0.3, -0.7], [1.1, 0.4]])
for target in ("numpy", "c"):
    m = symdyn.load(heavy, target)
    print(target, np.max(np.abs(m.tau(q, -q, 2 * q) - ref.rne(heavy, q, -q, 2 * q))))
"""


def test_an_unwritable_cache_folder_is_warned_about_once_and_done_without(tmp_path):
    """mkdir under a regular file fails even for root (who ignores permission bits)."""
    (tmp_path / "afile").write_text("not a folder")
    folder = tmp_path / "afile" / "cache"
    env = dict(os.environ, SYMDYN_CACHE_DIR=str(folder))
    run = subprocess.run([sys.executable, "-c", _UNWRITABLE], capture_output=True, text=True, env=env, timeout=600)
    assert run.returncode == 0, run.stderr
    lines = run.stdout.splitlines()
    assert lines[0] == "derive (2, 2)"
    for line, target in zip(lines[1:], ("numpy", "c")):
        name, error = line.split()
        assert name == target and float(error) < 1e-12, line
    warnings = [w for w in run.stderr.splitlines() if "not writable" in w]
    assert len(warnings) == 1 and str(folder) in warnings[0], run.stderr


def test_processes_that_want_the_same_derivation_build_it_once(tmp_path):
    """Two processes (test workers, a cluster's workers on one machine) derive the same arm
    at once into one cache: one builds it, the other waits for its lock and reads the entry."""
    script = (
        "import sys, time; from symdyn import models; from symdyn.derivation.entry import derive; "
        "time.sleep(max(0.0, float(sys.argv[1]) - time.time())); "
        "print(derive(models.load('puma560'), 'lagrange').stats['from_cache'])"
    )
    env = dict(os.environ, SYMDYN_CACHE_DIR=str(tmp_path))
    start = time.time() + 3.0  # both past their imports, then at once
    runs = [
        subprocess.Popen([sys.executable, "-c", script, str(start)], env=env, stdout=subprocess.PIPE, text=True)
        for _ in range(2)
    ]
    found = sorted(p.communicate(timeout=120)[0].strip() for p in runs)
    assert found == ["False", "True"], found
