"""The format registry (refimpl.io.formats): one row per format, read by every command."""

from __future__ import annotations

import numpy as np
import pytest

from refimpl import io
from refimpl.cli.parser import build_parser


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
        assert tuple(fmt.choices) == io.FORMAT_NAMES
