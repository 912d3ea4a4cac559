"""Every Python block of the README runs as written (issue 12, item 14)."""

import re
from pathlib import Path

README = Path(__file__).resolve().parent.parent / "README.md"


def python_blocks() -> list[str]:
    return re.findall(r"```python\n(.*?)```", README.read_text(), re.S)


def test_the_readme_has_python_examples():
    assert len(python_blocks()) >= 2


def test_every_readme_python_block_runs_in_order(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # from another directory, as a user would
    namespace: dict = {}
    for k, block in enumerate(python_blocks()):
        exec(compile(block, f"README.md python block {k + 1}", "exec"), namespace)
    np = namespace["np"]
    np.testing.assert_allclose(
        namespace["f"].fdyn(namespace["q"], namespace["qd"], namespace["tau"]), namespace["qdd"], atol=1e-10
    )
    np.testing.assert_allclose(
        namespace["g"].G([0.3, 0.2]), namespace["reference"].gravload(namespace["arm"], [0.3, 0.2]), rtol=1e-12
    )
