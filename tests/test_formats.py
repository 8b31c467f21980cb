"""The format registry (refimpl.io.formats): one row per format, read by every command."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import refimpl
from refimpl import io
from refimpl.cli import main
from refimpl.cli.parser import build_parser
from refimpl.evaluation.devkits import REFIMPL, TRACKEVAL, check_devkit, refimpl_rules
from refimpl.io.detections import resolve_rule, scale_confidences


def test_every_format_round_trips_its_results_rows(tmp_path):
    # two rows of frame 0/1 (KITTI numbers frames from 0, MOTChallenge from 1: use each format's own
    # first frame); boxes with two decimals survive the writers' two-decimal rounding exactly
    for fmt in io.FORMATS.values():
        f0 = fmt.first_frame
        rows = np.array([[f0, 1, 10.25, 20.5, 30.0, 40.75], [f0 + 1, 2, 0.5, 1.5, 2.25, 3.0]])
        path = tmp_path / f"{fmt.name}.txt"
        io.write_results(path, rows, fmt.name, first_frame=f0, object_class="car")
        back = io.read_results(path, fmt.name, object_class="car")
        np.testing.assert_allclose(back, rows, atol=1e-9)


def test_frame_numbering_and_class_needs_are_the_formats_own():
    assert (io.FORMATS[io.MOT].first_frame, io.FORMATS[io.MOT].needs_class) == (1, False)
    assert (io.FORMATS[io.KITTI].first_frame, io.FORMATS[io.KITTI].needs_class) == (0, True)
    with pytest.raises(ValueError, match="needs the object class"):
        io.write_results("unused.txt", np.zeros((0, 6)), io.KITTI)


def test_an_unknown_format_is_one_clear_error():
    with pytest.raises(ValueError, match=r"unknown format 'xml' \(known: mot, kitti\)"):
        io.get_format("xml")


def test_the_command_line_offers_exactly_the_registered_formats():
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    for command in ("track", "eval", "diff"):
        fmt = next(a for a in sub.choices[command]._actions if a.dest == "format")
        assert tuple(fmt.choices) == tuple(io.FORMAT_NAMES) == (io.MOT, io.KITTI)


# -- a format of one's own: one module (below, as it would be refimpl/io/formats/toy.py) + one row --

TOY = "toy"
TOY_IMAGE_SIZE, TOY_FPS = (320, 200), 5.0


def _read_toy(path, object_class=None, seqinfo=None, num_frames=None, scores_rule="auto"):
    """``frame;x1;y1;x2;y2;score`` lines, 0-based frames, scores probabilities (what "auto" means here)."""
    rows = np.array([[float(v) for v in line.split(";")] for line in Path(path).read_text().splitlines() if line])
    rule = resolve_rule(scores_rule, "probability")
    frames = []
    for number in range(int(rows[:, 0].max()) + 1):
        r = rows[rows[:, 0] == number]
        boxes = np.column_stack([r[:, 1], r[:, 2], r[:, 3] - r[:, 1], r[:, 4] - r[:, 2]])
        frames.append(io.DetectionFrame(number, boxes, r[:, 5], scale_confidences(path, (), r[:, 5], rule),
                                        ("pedestrian",) * len(r)))
    return io.DetectionSequence(Path(path).stem, tuple(frames), 0, TOY_IMAGE_SIZE, TOY_FPS)


def _format_toy(rows) -> str:
    return "".join(f"{int(f)};{int(i)};{x:.2f};{y:.2f};{w:.2f};{h:.2f}\n"
                   for f, i, x, y, w, h in sorted(map(tuple, np.asarray(rows, dtype=float))))


def _read_toy_results(path, object_class=None, allow_empty=False):
    return np.array([[float(v) for v in line.split(";")] for line in Path(path).read_text().splitlines()])


def _refused(*args, **kwargs):
    raise ValueError("the toy format has no ground truth and no stream")


TOY_FORMAT = io.DataFormat(
    TOY, "toy CSV", 0, False, read_detections=_read_toy, stream_detections=_refused, read_ground_truth=_refused,
    frames_from_gt=None, gt_layout="none", gt_candidates=lambda root, name: [], gt_names=lambda root: [],
    side_file=lambda dets: ("side", Path(dets).with_suffix(".side")),
    results_formatter=lambda first_frame, object_class: _format_toy,
    write_results=lambda path, rows, first_frame, object_class: Path(path).write_text(_format_toy(rows)),
    read_results=_read_toy_results,
    image_size=TOY_IMAGE_SIZE, fps=TOY_FPS, score_rule="probability", presets=io.MOT)


def _walker_files(tmp_path) -> tuple[Path, Path]:
    """One pedestrian walking right, 8 frames, score 0.95, and a crossing one from frame 2: the same
    detections as a toy file (0-based) and as a MOTChallenge det.txt (1-based, no seqinfo.ini)."""
    lines = [(k, 20 + 6 * k, 50, 60 + 6 * k, 130, 0.95) for k in range(8)]
    lines += [(k, 200 - 7 * k, 60, 236 - 7 * k, 140, 0.9) for k in range(2, 8)]
    toy, mot = tmp_path / "walk.toy", tmp_path / "MOT" / "det" / "det.txt"
    mot.parent.mkdir(parents=True)
    toy.write_text("".join(f"{f};{x1};{y1};{x2};{y2};{s}\n" for f, x1, y1, x2, y2, s in lines))
    mot.write_text("".join(f"{f + 1},-1,{x1},{y1},{x2 - x1},{y2 - y1},{s}\n" for f, x1, y1, x2, y2, s in lines))
    return toy, mot


def test_a_registered_format_is_gone_after_its_block():
    with io.registered(TOY_FORMAT):
        assert io.get_format(TOY) is TOY_FORMAT and TOY in io.FORMAT_NAMES
        with pytest.raises(ValueError, match="already registered"):
            with io.registered(TOY_FORMAT):
                pass
    assert TOY not in io.FORMATS and tuple(io.FORMAT_NAMES) == (io.MOT, io.KITTI)
    with pytest.raises(ValueError, match="unknown format 'toy'"):
        io.get_format(TOY)


def test_a_new_format_is_one_module_and_one_row_through_the_api(tmp_path):
    # expected: what the toy format decides (image size, frame rate, "auto" = probability, MOT's
    # presets, frames from 0) is what a caller of the MOT format would give by hand, so the toy file
    # tracks to exactly the rows of the same detections in MOTChallenge lines
    toy_path, mot_path = _walker_files(tmp_path)
    with io.registered(TOY_FORMAT):
        toy = refimpl.Tracker("cpsat", format=TOY, history=True)
        seq = io.get_format(TOY).read_detections(toy_path)
    mot = refimpl.Tracker("cpsat", format=io.MOT, img_size=TOY_IMAGE_SIZE, fps=TOY_FPS, scores="probability",
                          history=True)
    assert (toy.image_size, toy.fps, toy.scores, toy.first_frame) == (TOY_IMAGE_SIZE, TOY_FPS, "probability", 0)
    assert toy.setup == mot.setup  # the MOT preset, named by the toy row's presets
    mot_seq = io.read_mot_detections(mot_path, scores_rule="probability")
    for frame, mot_frame in zip(seq.frames, mot_seq.frames, strict=True):
        np.testing.assert_array_equal(frame.confidences, mot_frame.confidences)  # round(100 * score)
        dets = np.column_stack([frame.boxes[:, :2], frame.boxes[:, :2] + frame.boxes[:, 2:], frame.scores])
        np.testing.assert_array_equal(toy.update(dets), mot.update(dets))
    rows, mot_rows = toy.result().rows, mot.result().rows
    assert len(set(rows[:, 1])) == 2 and rows[:, 0].min() == 0  # two walkers, frames numbered from 0
    np.testing.assert_array_equal(rows[:, 1:], mot_rows[:, 1:])
    np.testing.assert_array_equal(rows[:, 0] + 1, mot_rows[:, 0])  # MOTChallenge numbers from 1


def test_a_new_format_is_one_module_and_one_row_through_the_command_line(tmp_path, capsys):
    # expected: `track --format toy` writes, in the toy's own lines, the rows `track` writes for the
    # same detections as a det.txt given the toy's image size, frame rate and score rule by hand
    toy_path, mot_path = _walker_files(tmp_path)
    toy_out, mot_out = tmp_path / "out.toy", tmp_path / "out.txt"
    with io.registered(TOY_FORMAT):
        assert main(["track", "--dets", str(toy_path), "--format", TOY, "--out-format", TOY, "--out", str(toy_out),
                     "--quiet"]) == 0
    assert main(["track", "--dets", str(mot_path), "--img-size", "320,200", "--fps", "5", "--scores", "probability",
                 "--out", str(mot_out), "--quiet"]) == 0
    rows, mot_rows = _read_toy_results(toy_out), io.read_mot_results(mot_out)
    assert len(rows) > 0 and len(set(rows[:, 1])) == 2
    np.testing.assert_allclose(rows[:, 1:], mot_rows[:, 1:])
    np.testing.assert_array_equal(rows[:, 0] + 1, mot_rows[:, 0])
    assert "walk: 8 frames, 2 tracks" in capsys.readouterr().out


def test_a_second_kitti_layout_format_gets_what_its_row_says_not_motchallenges_defaults(tmp_path):
    # expected: KITTI's own row values (1242 x 375, 10 fps, the kitti/car preset, the KITTI devkit's
    # convention line), read from the new row: nothing compares the name "kitti"
    label = tmp_path / "0000.txt"
    label.write_text("0 1 Car 0 0 -10 10 20 110 80 -1 -1 -1 -1000 -1000 -1000 -10\n"
                     "0 2 Van 0 0 -10 200 20 300 80 -1 -1 -1 -1000 -1000 -1000 -10\n")
    second = dataclasses.replace(io.FORMATS[io.KITTI], name="kitti-b", title="KITTI, another detector",
                                 presets=io.KITTI)
    with io.registered(second):
        b = refimpl.Tracker("cpsat", format="kitti-b", object_type="car")
        rules = refimpl_rules("kitti-b", "car", [])
        gt = io.get_format("kitti-b").read_ground_truth(label, object_class="car")
    kitti = refimpl.Tracker("cpsat", format=io.KITTI, object_type="car")
    assert (b.image_size, b.fps, b.first_frame, b.setup) == (kitti.image_size, kitti.fps, 0, kitti.setup)
    assert b.image_size == io.KITTI_IMAGE_SIZE and b.setup.preset == "kitti/car"
    assert rules == refimpl_rules(io.KITTI, "car", []) and "Van rows" in rules
    assert (gt.considered.tolist(), gt.distractor.tolist()) == ([True, False], [False, True])  # Car, Van


def test_a_format_without_devkit_conventions_is_not_offered_to_trackeval():
    with io.registered(TOY_FORMAT):
        with pytest.raises(ValueError, match="no dataset for --format toy"):
            check_devkit(TRACKEVAL, TOY, None)
        check_devkit(REFIMPL, TOY, None)  # refimpl's devkit scores what the reader flags
