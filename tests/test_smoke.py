"""The main job derives the Puma, writes its code, checks what it wrote and says so."""

import dataclasses
import re

import numpy as np

from symdyn import cli, models
from symdyn.numeric import reference as ref


def test_run_prints_the_book_numbers_and_checks_the_code_it_wrote(tmp_path, capsys):
    out = tmp_path / "puma"
    assert cli.main(["run", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    puma = models.load("puma560")
    g_qz = re.search(r"qz = .*\n  G\(q\)\s+= \[([^\]]*)\]", text).group(1).split()
    np.testing.assert_allclose([float(x) for x in g_qz], ref.gravload(puma, puma.qz), atol=1e-4)
    assert abs(float(g_qz[1]) - 37.4837) < 1e-4  # G2(qz), as Corke prints it
    worst = float(re.search(rf"in {re.escape(str(out))} vs reference .*max \|error\| (\S+)", text).group(1))
    assert worst < 1e-12
    assert {p.name for p in out.iterdir()} >= {"puma560.c", "puma560.h", "puma560.py", "puma560.casadi"}


def test_run_exits_nonzero_when_the_code_it_wrote_is_wrong(tmp_path, capsys, monkeypatch):
    """Fault injection: the written NumPy module is sealed and current but computes the wrong
    gravity (one wrong target suffices; the C and CasADi files stay right, so that their
    library is the one every Puma test shares rather than a compile of its own)."""
    from symdyn.codegen.emit import numpy as np_emit

    right = np_emit.module_source

    def wrong(b):  # G 1 % too large; a fault in the programs needs no second derivation
        return right(
            dataclasses.replace(
                b,
                programs=tuple(
                    dataclasses.replace(p, outputs=tuple((o, m * 1.01) for o, m in p.outputs)) if p.name == "G" else p
                    for p in b.programs
                ),
            )
        )

    monkeypatch.setattr(np_emit, "module_source", wrong)
    assert cli.main(["run", "--out", str(tmp_path / "puma")]) == 1
    assert "disagrees with the reference" in capsys.readouterr().err
