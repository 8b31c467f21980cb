"""Plots: the command writes real PNG files (space-time picture and one frame) that matplotlib reads back."""

from __future__ import annotations

import pytest

from refimpl import cli
from refimpl.scene import SceneError, save_scene

from test_scene import bus_scene

pytest.importorskip("matplotlib")

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def read_png(path):
    import matplotlib.image
    return matplotlib.image.imread(str(path))


@pytest.fixture
def scene_file(tmp_path):
    path = tmp_path / "bus.json"
    save_scene(path, bus_scene())
    return str(path)


def test_plot_command_writes_a_space_time_png(scene_file, tmp_path, capsys):
    out = tmp_path / "timeline.png"
    # all four tracks named (trk_7 has only 2 observed frames, below the default cut of 3)
    assert cli.main(["plot", scene_file, "--out", str(out), "--tracks", "5,7,12,13"]) == 0
    assert "4 tracks" in capsys.readouterr().out
    data = out.read_bytes()
    assert data.startswith(PNG_SIGNATURE) and len(data) > 10_000
    image = read_png(out)
    assert image.ndim == 3 and image.shape[0] > 200 and image.shape[1] > 1000


def test_plot_command_writes_one_frame_png(scene_file, tmp_path, capsys):
    out = tmp_path / "frame.png"
    assert cli.main(["plot", scene_file, "--out", str(out), "--frame", "245"]) == 0
    assert "3 boxes" in capsys.readouterr().out  # bus, hidden car (dashed), pedestrian trk_5
    assert out.read_bytes().startswith(PNG_SIGNATURE)
    assert read_png(out).shape[1] > 1000


def test_frame_relations_list_the_hidden_car_behind_the_bus():
    from refimpl.scene.plots import frame_relation_lines
    s = bus_scene()
    at = 245
    lines = frame_relation_lines(s, at, [t for t in s.tracks if t.box_at(at)])
    # the car's predicted box x = 155..195 lies inside the bus x 100..300, y 120..180 in 100..200:
    # a non-tangential proper part, overlapping_top, its bottom (180) above the bus's (200): behind
    assert "hidden_by(trk_13,trk_12)" in lines
    assert "  12 13   ntppi, in_front_of, near" in lines


def test_halted_spans_split_resumed_from_ended():
    from refimpl.scene.plots import halted_spans
    s = bus_scene()
    assert halted_spans(s, s.track("trk_13")) == [(235, 267, True)]
    assert halted_spans(s, s.track("trk_5")) == [(210, 211, True)]


@pytest.mark.parametrize("argv, message", [
    (["--frame", "999"], "frame 999 is outside the scene (200-280)"),
    (["--frames", "260-250"], "--frames must be FROM:TO"),
    (["--tracks", "99"], "no track trk_99"),
])
def test_plot_mistakes_are_one_line_errors(scene_file, tmp_path, capsys, argv, message):
    code = cli.main(["plot", scene_file, "--out", str(tmp_path / "x.png"), *argv])
    err = capsys.readouterr().err
    assert code == 2 and message in err and err.count("\n") == 1
    assert not (tmp_path / "x.png").exists()


def test_plot_into_a_missing_folder_creates_it_and_under_a_file_is_an_error(scene_file, tmp_path):
    # every output's folder is created if missing (refimpl.io.outputs); a file on the path is an error
    from refimpl.io.outputs import OutputError
    from refimpl.scene.plots import plot_scene_file
    plot_scene_file(scene_file, str(tmp_path / "no" / "x.png"))
    assert (tmp_path / "no" / "x.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(OutputError, match="not a directory"):
        plot_scene_file(scene_file, str(tmp_path / "no" / "x.png" / "y.png"))
