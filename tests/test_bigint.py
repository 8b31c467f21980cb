"""Integers of any size in refimpl's outputs (issue 41, item 2): Python refuses to turn an int of
more than sys.get_int_max_str_digits() digits into text (4300 by default), and a dense crowd's
level 0 (the tie-break, docs/model.md 3.10) is far longer; refimpl.core.bigint prints and reads
them without changing that process-wide limit."""

from __future__ import annotations

import json
import sys
from contextlib import contextmanager

import pytest

from refimpl import cli
from refimpl.core import bigint
from refimpl.core.spec import Detection, FrameProblem, TrackPrediction
from refimpl.experiments.synthetic import iou_facts
from refimpl.scene.files import load_scene


@contextmanager
def digit_limit(n: int):
    """Python's integer-string limit set to n digits (0: none) inside the block, restored after."""
    old = sys.get_int_max_str_digits()
    sys.set_int_max_str_digits(n)
    try:
        yield
    finally:
        sys.set_int_max_str_digits(old)


def test_int_text_and_parse_int_on_numbers_whose_digits_are_known():
    # 10^5000 - 1 is 5000 nines; 7 * 10^4999 + 3 is a 7, 4998 zeros and a 3 (the zeros inside
    # are where a split into parts must pad); both beyond the default limit of 4300 digits
    nines = 10 ** 5000 - 1
    seven = 7 * 10 ** 4999 + 3
    assert bigint.int_text(nines) == "9" * 5000
    assert bigint.int_text(seven) == "7" + "0" * 4998 + "3"
    assert bigint.int_text(-seven) == "-7" + "0" * 4998 + "3"
    assert bigint.int_text(10 ** 4300) == "1" + "0" * 4300
    assert bigint.int_text(0) == "0" and bigint.int_text(-12) == "-12"
    assert bigint.parse_int("9" * 5000) == nines
    assert bigint.parse_int("-7" + "0" * 4998 + "3") == -seven
    assert bigint.parse_int("+0012") == 12
    for bad in ("", "-", "1.5", "12a", "١٢"):  # the last: Arabic-Indic digits, which int() takes
        with pytest.raises(ValueError):
            bigint.parse_int(bad)


def test_dumps_is_the_standard_librarys_text_and_any_int_round_trips():
    value = {"cost": [[10, -454480], [0, 648]], "ok": True, "none": None, "x": 1.5, "s": "é\"", "e": [], "d": {}}
    for kw in ({}, {"indent": 1}, {"indent": 2}, {"separators": (",", ":")}):
        assert bigint.dumps(value, **kw) == json.dumps(value, **kw)
    big = {"cost": [[0, 3 ** 20000]]}  # 9543 digits (20000 * log10 3 = 9542.4)
    text = bigint.dumps(big, indent=1)
    assert bigint.loads(text) == big
    with digit_limit(0):  # the standard library, with no limit, reads the same text
        assert json.loads(text) == big and len(str(3 ** 20000)) == 9543


def band_frame(n: int) -> FrameProblem:
    """n car tracks of 100 x 100 px, 5 px apart along x, each with a detection on exactly its box.
    Two boxes d steps apart have IoU (100 - 5d) / (100 + 5d): 50/150 > 0.3 at d = 10, 45/155 < 0.3
    at d = 11, so (trk_i, det_j) is assignable iff |i - j| <= 10, and the frame is one component."""
    tracks = tuple(TrackPrediction(f"trk_{i}", "car", "active", (100 + 5 * i, 100, 100, 100)) for i in range(n))
    dets = tuple(Detection(f"det_{i}", "car", 90, (100 + 5 * i, 100, 100, 100)) for i in range(n))
    return FrameProblem(time=10, detections=dets, tracks=tracks, iou=iou_facts(tracks, dets))


def band_pair_sum(n: int) -> int:
    """The tie-break's pair part of assign(trk_i, det_i) for every i (docs/model.md 3.10): 2^q with
    q the rank of the pair among the component's pairs in natural order (trk_0's 11 pairs, then
    trk_1's 12, ...; trk_i's pairs are det_max(0,i-10) .. det_min(n-1,i+10))."""
    total, before = 0, 0
    for i in range(n):
        lo, hi = max(0, i - 10), min(n - 1, i + 10)
        total += 1 << (before + i - lo)
        before += hi - lo + 1
    return total


@pytest.mark.parametrize("output", ["plain", "json"])
def test_solve_prints_a_level_0_longer_than_pythons_limit(backend, output, tmp_path, capsys):
    # 110 tracks: 2200 assignable pairs, so trk_109's pair has rank 2199 and level 0 has more than
    # 2199 * log10(2) = 662 digits.  Python's limit is lowered to its smallest, 640, so this cheap
    # frame meets the wall a dense 400-track crowd meets at 4300 (issue 41: 4,565 digits).
    n = 110
    path = tmp_path / "band.lp"
    path.write_text(band_frame(n).to_facts())
    with digit_limit(640):
        code = cli.main(["solve", str(path), "--backend", backend] + (["--json"] if output == "json" else []))
    out = capsys.readouterr().out
    assert code == 0
    with digit_limit(0):
        if output == "json":
            answer = json.loads(out)
            cost = {p: v for p, v in answer["cost"]}
            assert answer["optimal"] is True
        else:
            last = out.splitlines()[-1]
            assert last.startswith("cost:")
            cost = {int(p): int(v) for v, p in (x.split("@") for x in last.split()[1:])}
    # every track takes its own detection: level 10 = -(100000 + 1) * 110; nothing else costs
    assert cost[10] == -100001 * n and cost[5] == cost[3] == cost[2] == cost[1] == 0
    pairs = band_pair_sum(n)
    shift, rest = divmod(cost[0], pairs)
    # level 0 = pairs * 2^E + (no events: 0), E the bit length of a small index bound
    assert rest == 0 and shift & (shift - 1) == 0 and shift < 2 ** 16
    with digit_limit(0):
        assert len(str(cost[0])) > 640


def test_a_scene_file_with_an_integer_beyond_pythons_limit_is_one_line(tmp_path, capsys):
    # json.load itself used to refuse it with "Exceeds the limit (4300 digits) ..."; the reader
    # now reads any integer and names what is wrong: no scene number is 5000 digits long
    path = tmp_path / "s.json"
    path.write_text('{"format": "refimpl-scene", "version": 1, "first_frame": ' + "9" * 5000 + "}")
    assert cli.main(["explain", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "an integer of 5000 digits" in err
    with pytest.raises(ValueError, match="5000 digits"):
        load_scene(path)
