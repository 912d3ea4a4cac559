"""A picture (issue 34, item 5): `symdyn show FILE --out robot.png` and `robot.plot()` draw the
chain, joint axes, centres of mass, inertia ellipsoids and the URDF tree's locked and excluded parts."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from symdyn import Link, Robot
from symdyn.cli import main
from symdyn.presentation.picture import ellipsoid_axes, frames

pytest.importorskip("matplotlib")

URDF = Path(__file__).parent / "urdf" / "branches.urdf"


def _two_link() -> Robot:
    links = [Link(a=1, m=1, r=(-0.5, 0, 0), I=np.diag([0.01, 0.1, 0.1]).tolist()) for _ in range(2)]
    return Robot("two", links)


def test_plot_draws_the_chain_axes_coms_and_ellipsoids_of_a_small_robot():
    fig = _two_link().plot()
    (ax,) = fig.axes
    assert len(ax.lines) == 1  # the chain: base, joints, tool
    # per link a joint-axis arrow, a centre of mass and an ellipsoid; the tool's frame (three
    # arrows and a marker); one arrow for the legend
    assert len(ax.collections) == 2 * 3 + 4 + 1
    assert [t.get_text() for t in ax.texts] == ["q1", "q2", " tool"]


def test_the_task_frames_are_marked_where_they_are():
    robot = Robot.from_urdf(URDF, tip_link="hand", exclude=["camera", "finger"])
    robot = robot.with_frames(["hand", robot.frame_names[0]])
    ax = robot.plot().axes[0]
    texts = {t.get_text().strip(): t.get_position() for t in ax.texts}
    assert {"hand", robot.frame_names[0]} <= set(texts)
    assert "task frames (x y z: red green blue)" in {t.get_text() for t in ax.figure.legends[0].get_texts()}


def test_the_frames_are_the_forward_kinematics():
    T = frames(_two_link(), [np.pi / 2, 0])
    assert np.allclose(T[-1][:3, 3], [0, 2, 0])


def test_an_ellipsoid_has_the_bodys_mass_and_moments():
    semi, _ = ellipsoid_axes(2.0, np.diag([1.0, 2.0, 2.5]))
    a, b, c = semi
    assert np.allclose(2.0 / 5 * np.array([b * b + c * c, a * a + c * c, a * a + b * b]), [1.0, 2.0, 2.5])


def test_a_urdf_robot_shows_its_locked_and_excluded_parts():
    robot = Robot.from_urdf(URDF, tip_link="hand", locked={"j4": 0.5}, exclude=["camera", "finger"])
    roles = {b.link: b.role for b in robot.urdf.skeleton}
    assert roles["camera"] == "excluded" and roles["fingertip"] == "excluded" and roles["hand"] == "chain"
    ax = robot.plot().axes[0]
    labels = ax.figure.legends[0].get_texts()
    said = {t.get_text() for t in labels}
    assert {"excluded (left out)", "locked joint", "chain (moving)"} <= said


def test_show_writes_a_png(tmp_path, capsys):
    out = tmp_path / "robot.png"
    assert (
        main(["show", str(URDF), "--tip", "hand", "--exclude", "camera", "--exclude", "finger", "--out", str(out)]) == 0
    )
    assert out.stat().st_size > 10_000 and out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert f"wrote {out}" in capsys.readouterr().out
