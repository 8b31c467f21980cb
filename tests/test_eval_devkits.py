"""`refimpl eval` names its convention, and `--devkit trackeval` gives TrackEval's own numbers.

* Hand-made sequences whose removals are counted by hand show what each devkit does (KITTI: Van,
  DontCare, a truncated target, a small box; MOTChallenge: a MOT20 non-MOT-vehicle row).
* Two real cases -- KITTI Car 0011 tracked by the abduction tracker (conftest.py) and MOT15
  TUD-Campus tracked by the baseline -- scored by `refimpl eval --devkit trackeval` and by
  TrackEval's Evaluator run directly on the files (tests/tools/trackeval_agreement.py's runners): every
  metric of the table equal.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from refimpl.cli import main

pytest.importorskip("trackeval")

REPO = Path(__file__).resolve().parent.parent
MOT15 = REPO.parent / "shared" / "data" / "MOT15" / "train"

TABLE_KEYS = ("HOTA", "DetA", "AssA", "MOTA", "MOTP", "IDF1", "MT", "ML", "FP", "FN", "IDs", "Frag")


def _eval(capsys, argv: list[str], json_path: Path) -> tuple[list[str], dict]:
    assert main(["eval", *argv, "--json", str(json_path)]) == 0
    out = capsys.readouterr().out.splitlines()
    return out, json.loads(json_path.read_text())


def _label(frame, ident, kind, x1, y1, x2, y2, truncated=0, occluded=0) -> str:
    return f"{frame} {ident} {kind} {truncated} {occluded} -10 {x1} {y1} {x2} {y2} -1 -1 -1 -1000 -1000 -1000 -10"


# ---------------------------------------------------------------------------------------
# what each devkit removes, counted by hand


def test_kitti_conventions_on_a_hand_made_frame(tmp_path, capsys):
    # frame 0: Car 1 (100..200), Van 2 (300..400), DontCare (500..600), Car 3 (700..800) truncated 1;
    # five hypotheses: on Car 1, on the Van, inside the DontCare region, on Car 3, and a 20 px high
    # box matching nothing (900..950 x 100..120)
    gt = tmp_path / "label_02" / "0000.txt"
    gt.parent.mkdir()
    gt.write_text("\n".join([_label(0, 1, "Car", 100, 100, 200, 200), _label(0, 2, "Van", 300, 100, 400, 200),
                             _label(0, -1, "DontCare", 500, 100, 600, 200),
                             _label(0, 3, "Car", 700, 100, 800, 200, truncated=1)]) + "\n")
    res = tmp_path / "0000.txt"
    res.write_text("0,1,100,100,100,100,1,-1,-1,-1\n0,2,300,100,100,100,1,-1,-1,-1\n0,3,510,110,80,80,1,-1,-1,-1\n"
                   "0,4,700,100,100,100,1,-1,-1,-1\n0,5,900,100,50,20,1,-1,-1,-1\n")
    argv = [str(res), "--gt", str(gt), "--format", "kitti", "--class", "Car"]

    out, ours = _eval(capsys, argv, tmp_path / "a.json")
    # refimpl: the Van hit and the DontCare box are removed (2 of 5); targets Car 1 and Car 3, both
    # matched; the small box is a false positive: MOTA = 1 - 1/2
    assert out[0] == ("convention: KITTI Car, simplified devkit (refimpl): targets Car rows; removed: hypotheses "
                      "matched (IoU >= 0.5) to Van rows, unmatched hypotheses at least 50% inside DontCare; no "
                      "truncation/occlusion filter, no minimum height; 2 of 5 hypotheses removed")
    assert out[1].startswith("| Sequence | HOTA |")
    assert ours["devkit"] == "refimpl" and ours["convention"] == out[0].removeprefix("convention: ")
    assert ours["overall"]["MOTA"] == 0.5 and ours["overall"]["FP"] == 1 and ours["overall"]["FN"] == 0

    out, theirs = _eval(capsys, [*argv, "--devkit", "trackeval"], tmp_path / "b.json")
    # Kitti2DBox also removes the hit on the truncated Car 3 (no longer a target) and the unmatched
    # box of 20 <= 25 px: 4 of 5 removed, one target, one true positive, MOTA 1
    assert out[0].startswith("convention: KITTI Car, TrackEval Kitti2DBox (the KITTI devkit's rules): targets Car "
                             "rows with truncation <= 0 and occlusion <= 2;")
    assert out[0].endswith("; 4 of 5 hypotheses removed")
    assert theirs["devkit"] == "trackeval"
    assert theirs["overall"]["MOTA"] == 1.0 and theirs["overall"]["FP"] == 0 and theirs["overall"]["FN"] == 0


def test_mot20_non_mot_vehicle_is_a_distractor_only_for_trackeval(tmp_path, capsys):
    # MOT20-99, 9-field ground truth: a pedestrian (class 1) and a non-MOT vehicle (class 6, flag 0);
    # a hypothesis on each.  refimpl's distractors are classes 2, 7, 8, 12: the second hypothesis is
    # a false positive (MOTA 1 - 1/1 = 0); TrackEval's MOT20 rules add class 6: it is removed (MOTA 1).
    gt = tmp_path / "MOT20-99" / "gt" / "gt.txt"
    gt.parent.mkdir(parents=True)
    gt.write_text("1,1,10,10,50,100,1,1,1.0\n1,2,200,10,80,60,0,6,1.0\n")
    res = tmp_path / "res.txt"
    res.write_text("1,1,10,10,50,100,1,-1,-1,-1\n1,2,200,10,80,60,1,-1,-1,-1\n")
    out, ours = _eval(capsys, [str(res), "--gt", str(gt)], tmp_path / "a.json")
    assert out[0] == ("convention: MOTChallenge, simplified devkit (refimpl): MOT16/17/20 ground truth: targets rows "
                      "with flag != 0 and class 1; removed: hypotheses matched (IoU >= 0.5) to rows of class 2, 7, "
                      "8, 12; 0 of 2 hypotheses removed")
    assert ours["overall"]["MOTA"] == 0.0
    out, theirs = _eval(capsys, [str(res), "--gt", str(gt), "--devkit", "trackeval"], tmp_path / "b.json")
    assert out[0] == ("convention: MOTChallenge, TrackEval MotChallenge2DBox BENCHMARK MOT20: targets rows with "
                      "flag != 0 and class 1; removed: hypotheses matched (IoU >= 0.5) to rows of class 2, 6, 7, "
                      "8, 12; 1 of 2 hypotheses removed")
    assert theirs["overall"]["MOTA"] == 1.0


def test_trackeval_gets_dense_ids_so_a_huge_track_id_changes_no_score(tmp_path, capsys):
    # TrackEval sizes an array by a sequence's largest id (np.ones(max(ids) + 1)): a track id of
    # 2^40 asked for 8 TiB (issue 37).  The ids are now handed over as their ranks (0..K-1), a
    # monotone map, so every score equals the run with small ids.  Two frames: gt tracks 1 and 2,
    # hypotheses that follow them but swap ids in frame 2 (an id switch each: IDs = 2).
    gt = tmp_path / "MOT20-99" / "gt" / "gt.txt"
    gt.parent.mkdir(parents=True)
    res = tmp_path / "res.txt"
    scores = []
    for a, b in ((1, 2), (2 ** 40, 2 ** 40 + 7)):
        gt.write_text(f"1,{a},10,10,50,100,1,1,1.0\n1,{b},200,10,80,60,1,1,1.0\n"
                      f"2,{a},12,10,50,100,1,1,1.0\n2,{b},202,10,80,60,1,1,1.0\n")
        res.write_text(f"1,{b},10,10,50,100,1,-1,-1,-1\n1,{a},200,10,80,60,1,-1,-1,-1\n"
                       f"2,{a},12,10,50,100,1,-1,-1,-1\n2,{b},202,10,80,60,1,-1,-1,-1\n")
        _, theirs = _eval(capsys, [str(res), "--gt", str(gt), "--devkit", "trackeval"], tmp_path / f"{a}.json")
        scores.append(theirs["overall"])
    assert scores[0]["IDs"] == 2 and scores[0]["MOTA"] == 0.5  # 1 - (0 FN + 0 FP + 2 IDs) / 4
    assert scores[1] == scores[0]


def test_trackeval_devkit_refuses_what_kitti2dbox_cannot_score(tmp_path, capsys):
    res = tmp_path / "r.txt"
    res.write_text("0,1,100,100,100,100,1,-1,-1,-1\n")
    gt = tmp_path / "g.txt"
    gt.write_text(_label(0, 1, "Cyclist", 100, 100, 200, 200) + "\n")
    argv = ["eval", str(res), "--gt", str(gt), "--format", "kitti", "--class", "Cyclist"]
    assert main([*argv, "--devkit", "trackeval"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Car and Pedestrian only" in err and "--devkit refimpl" in err
    assert main(argv) == 0  # refimpl's devkit scores Cyclist
    assert capsys.readouterr().out.startswith("convention: KITTI Cyclist, simplified devkit (refimpl): targets "
                                              "Cyclist rows; removed: unmatched hypotheses at least 50% inside")


# ---------------------------------------------------------------------------------------
# real sequences: --devkit trackeval against TrackEval run directly


def _agree(mine: dict, te: dict) -> None:
    """refimpl's JSON row against one entry of TrackEval's Evaluator result, every table metric."""
    h, c, i = te["HOTA"], te["CLEAR"], te["Identity"]
    theirs = {"HOTA": np.mean(h["HOTA"]), "DetA": np.mean(h["DetA"]), "AssA": np.mean(h["AssA"]),
              "MOTA": c["MOTA"], "MOTP": c["MOTP"], "IDF1": i["IDF1"], "MT": c["MT"], "ML": c["ML"],
              "FP": c["CLR_FP"], "FN": c["CLR_FN"], "IDs": c["IDSW"], "Frag": c["Frag"]}
    assert {k: mine[k] for k in TABLE_KEYS} == {k: float(v) if k in ("HOTA", "DetA", "AssA", "MOTA", "MOTP", "IDF1")
                                                else int(v) for k, v in theirs.items()}


def test_kitti_car_0011_trackeval_devkit_equals_trackeval_run_directly(kitti_car_0011, tmp_path, capsys):
    from tools.trackeval_agreement import trackeval_kitti
    label = kitti_car_0011["label"]
    kitti_file = kitti_car_0011["results"]  # the abduction tracker's results, KITTI tracking format
    trackers = kitti_file.parent.parent.parent  # TRACKERS_FOLDER/refimpl/data/0011.txt

    # TrackEval directly: GT_FOLDER/label_02/0011.txt and a seqmap naming its 373 frames (0..372,
    # the label file's last frame + 1, as KITTI's own training seqmap says)
    gt_root = tmp_path / "gt"
    (gt_root / "label_02").mkdir(parents=True)
    shutil.copy(label, gt_root / "label_02" / "0011.txt")
    frames = 1 + max(int(line.split()[0]) for line in label.read_text().splitlines() if line.strip())
    assert frames == 373
    (gt_root / "evaluate_tracking.seqmap.training").write_text(f"0011 empty 000000 {frames:06d}\n")
    direct = trackeval_kitti(gt_root, trackers, "car", "training")
    capsys.readouterr()

    argv = ["--gt", str(label), "--format", "kitti", "--class", "Car", "--devkit", "trackeval"]
    out, mine = _eval(capsys, [str(kitti_file), *argv], tmp_path / "k.json")
    _agree(mine["sequences"]["0011"], direct["0011"])
    _agree(mine["overall"], direct["COMBINED_SEQ"])
    # the removed count is TrackEval's: rows written minus the detections its Count metric kept
    rows = len(kitti_file.read_text().splitlines())
    assert out[0].endswith(f"; {rows - direct['0011']['Count']['Dets']} of {rows} hypotheses removed")

    # the same boxes as MOTChallenge lines x, y, x2 - x1, y2 - y1 (refimpl converts them back with
    # x2 = x + w, equal to the file's x2 up to one rounding of the last bit): the same numbers
    with_mot = tmp_path / "0011.txt"
    with_mot.write_text("".join(
        f"{f[0]},{f[1]},{float(f[6])!r},{float(f[7])!r},{float(f[8]) - float(f[6])!r},"
        f"{float(f[9]) - float(f[7])!r},1,-1,-1,-1\n" for f in map(str.split, kitti_file.read_text().splitlines())))
    _, lines = _eval(capsys, [str(with_mot), *argv], tmp_path / "m.json")
    for key in TABLE_KEYS:
        assert lines["overall"][key] == pytest.approx(mine["overall"][key], abs=1e-12)



def test_mot15_tud_campus_trackeval_devkit_equals_trackeval_run_directly(shared_data, tmp_path, capsys):
    from tools.trackeval_agreement import trackeval_mot
    seq = MOT15 / "TUD-Campus"
    trackers = tmp_path / "trackers"
    results = trackers / "refimpl" / "data" / "TUD-Campus.txt"
    assert main(["track", "--dets", str(seq / "det" / "det_sort_frcnn.txt"), "--out", str(results)]) == 0
    capsys.readouterr()
    direct = trackeval_mot(MOT15, trackers, ["TUD-Campus"], "MOT15")
    capsys.readouterr()
    out, mine = _eval(capsys, [str(results), "--gt", str(seq / "gt" / "gt.txt"), "--devkit", "trackeval"],
                      tmp_path / "t.json")
    assert out[0].startswith("convention: MOTChallenge, TrackEval MotChallenge2DBox BENCHMARK MOT15: targets rows "
                             "with flag != 0; no distractors; 0 of ")
    _agree(mine["sequences"]["TUD-Campus"], direct["TUD-Campus"])
    _agree(mine["overall"], direct["COMBINED_SEQ"])
