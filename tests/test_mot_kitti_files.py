"""refimpl.io: reading MOTChallenge / KITTI files, error discipline, atomic result writing."""

from __future__ import annotations

import os
import pickle
import re
from pathlib import Path

import numpy as np
import pytest

from refimpl.io.datasets import benchmark_sequences, tuning_split
from refimpl import io
from refimpl.io import InputFormatError, InputFormatWarning

DATA = Path(os.environ.get("REFIMPL_DATA_ROOT", Path(__file__).resolve().parent.parent.parent / "shared" / "data"))
needs_data = pytest.mark.skipif(
    not (DATA / "PROVENANCE.md").is_file(),
    reason=f"benchmark data folder {DATA} absent (set REFIMPL_DATA_ROOT to run these)")
MOT15 = DATA / "MOT15" / "train"
KITTI = DATA / "KITTI" / "tracking" / "training"

SEQINFO = "[Sequence]\nname=Tiny\nimDir=img1\nframeRate=25\nseqLength={n}\nimWidth=640\nimHeight=480\nimExt=.jpg\n"


def write(path: Path, text: str | bytes) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text)
    return path


def raises_at(path: Path, line: int | None, reason_part: str):
    """pytest.raises for InputFormatError whose message starts with '<path>:<line>: '."""
    where = f"{path}:{line}: " if line is not None else f"{path}: "
    return pytest.raises(InputFormatError, match="^" + re.escape(where) + ".*" + re.escape(reason_part))


# ---------------------------------------------------------------------------------------
# real benchmark files (exact counts from ../shared/data/PROVENANCE.md)


@needs_data
def test_tud_campus_sort_frcnn_detections_cover_all_71_frames():
    seq = io.read_mot_detections(MOT15 / "TUD-Campus" / "det" / "det_sort_frcnn.txt", scores_rule="probability")
    # PROVENANCE: det_sort_frcnn.txt has 321 rows; seqinfo seqLength=71, 640x480, 25 fps
    assert seq.num_detections == 321
    assert seq.num_frames == 71
    assert [f.frame for f in seq.frames] == list(range(1, 71 + 1))
    assert (seq.name, seq.first_frame, seq.image_size, seq.fps) == ("TUD-Campus", 1, (640, 480), 25.0)
    conf = np.concatenate([f.confidences for f in seq.frames])
    # scores are 0.50..1.00 -> round(100*score) lies in 50..100
    assert conf.min() >= 50 and conf.max() <= 100
    assert seq.frames[0].confidences[0] == 100  # first row score 0.997784 -> round(99.7784) = 100
    assert set(t for f in seq.frames for t in f.types) == {"pedestrian"}


@needs_data
def test_official_acf_detections_use_clipped_raw_scores():
    seq = io.read_mot_detections(MOT15 / "TUD-Campus" / "det" / "det.txt", scores_rule="raw")
    assert seq.num_detections == 322  # PROVENANCE: official det.txt, 322 rows
    # first row score 42.848 (not all scores in [0,1]) -> clip(round(42.848), 0, 100) = 43
    assert seq.frames[0].confidences[0] == 43
    assert seq.frames[0].scores[0] == pytest.approx(42.848)
    conf = np.concatenate([f.confidences for f in seq.frames])
    assert conf.max() == 100  # 4 rows score above 100 (up to 117.88) are clipped to 100


@needs_data
def test_empty_frames_are_present_in_kitti13_detections():
    seq = io.read_mot_detections(MOT15 / "KITTI-13" / "det" / "det_sort_frcnn.txt")
    # KITTI-13: seqLength 340, 945 rows on 284 distinct frames (first frame 4)
    assert seq.num_frames == 340
    assert seq.num_detections == 945
    empty = [f.frame for f in seq.frames if len(f) == 0]
    assert len(empty) == 340 - 284
    assert empty[:3] == [1, 2, 3]
    assert seq.frames[0].boxes.shape == (0, 4)


@needs_data
def test_kitti_0000_car_detections_keep_1054_rows_minus_one_recorded_zero_width_box():
    with pytest.warns(InputFormatWarning, match="line\\(s\\) 614"):
        seq = io.read_kitti_detections(KITTI / "det_02_pointrcnn" / "Car" / "0000.txt", "car", scores_rule="sigmoid")
    # PROVENANCE: 1,054 rows; line 614 is "115,2,1241.0000,...,1241.0000,..." (x1 == x2)
    assert seq.num_detections + len(seq.dropped) == 1054
    assert [line for line, _ in seq.dropped] == [614]
    # num_frames from ../../label_02/0000.txt: frames 0..153
    assert seq.num_frames == 154 and seq.first_frame == 0
    assert seq.image_size == (1242, 375) and seq.fps == 10.0
    # line 3 has raw score -0.4501 -> round(100 / (1 + e^0.4501)) = round(38.93) = 39
    assert seq.frames[0].confidences[2] == 39
    assert seq.frames[0].types[0] == "car"


@needs_data
def test_kitti_0000_labels_have_243_cars_with_292_van_distractors_and_378_dontcare():
    gt = io.read_kitti_ground_truth(KITTI / "label_02" / "0000.txt", "car")
    # PROVENANCE table: 0000 has 243 Car rows; `awk '{print $3}' | uniq -c` gives 292 Van, 378 DontCare
    assert gt.num_targets == 243
    assert int(gt.distractor.sum()) == 292
    assert len(gt.frames) == 243 + 292
    assert gt.dontcare.shape == (378, 5)
    assert (gt.first_frame, gt.num_frames) == (0, 154)
    ped = io.read_kitti_ground_truth(KITTI / "label_02" / "0000.txt", "pedestrian")
    assert ped.num_targets == 22 and int(ped.distractor.sum()) == 0


@needs_data
def test_kitti_pedestrian_distractors_are_the_person_rows():
    gt = io.read_kitti_ground_truth(KITTI / "label_02" / "0019.txt", "pedestrian")
    # PROVENANCE: 0019 has 6,088 Pedestrian rows; `grep -c " Person "` gives 509 Person (sitting) rows
    assert gt.num_targets == 6088
    assert int(gt.distractor.sum()) == 509


@needs_data
def test_mot17_ground_truth_follows_devkit_consider_and_class_rules():
    total_boxes, total_ids = 0, 0
    for name in ("02", "04", "05", "09", "10", "11", "13"):
        gt = io.read_mot_ground_truth(DATA / "MOT17" / "train" / f"MOT17-{name}-FRCNN" / "gt" / "gt.txt")
        total_boxes += gt.num_targets
        total_ids += len(np.unique(gt.ids[gt.considered]))
        if name == "02":
            # PROVENANCE: MOT17-02 has 30,003 lines, 18,581 pedestrian boxes over 62 ids, seqLength 600
            assert len(gt.frames) == 30003
            assert gt.num_targets == 18581
            assert gt.num_frames == 600
            assert gt.visibility.min() >= 0.0 and gt.visibility.max() <= 1.0
    # PROVENANCE: official MOT17 train statistics, 112,297 pedestrian boxes and 546 tracks
    assert (total_boxes, total_ids) == (112297, 546)


@needs_data
def test_mot15_ground_truth_counts_rows_with_nonzero_flag():
    gt = io.read_mot_ground_truth(MOT15 / "TUD-Campus" / "gt" / "gt.txt")
    # PROVENANCE: 359 lines, all flagged 1, seqLength 71
    assert gt.num_targets == 359 and gt.num_frames == 71 and not gt.distractor.any()
    assert np.all(gt.visibility == 1.0)


@needs_data
def test_benchmark_sequences_list_the_documented_sequences():
    mot15 = benchmark_sequences("mot15", DATA)
    assert len(mot15) == 11
    assert all(s.dets_path.name == "det_sort_frcnn.txt" and s.format == "mot" for s in mot15)
    sort6 = benchmark_sequences("mot15-sort6", DATA)
    assert [s.name for s in sort6] == ["TUD-Campus", "ETH-Sunnyday", "ETH-Pedcross2", "ADL-Rundle-8",
                                       "Venice-2", "KITTI-17"]
    for name, cls, det_dir in (("kitti-car", "car", "Car"), ("kitti-ped", "pedestrian", "Pedestrian")):
        seqs = benchmark_sequences(name, DATA)
        assert [s.name for s in seqs] == [f"{i:04d}" for i in range(21)]
        assert all(s.object_class == cls and s.dets_path.parent.name == det_dir for s in seqs)


@needs_data
def test_the_held_out_benchmarks_list_the_documented_sequences():
    # PROVENANCE.md: the official ACF det/det.txt is there for 7 of the 11 MOT15 training sequences
    acf = benchmark_sequences("mot15-acf", DATA)
    assert [s.name for s in acf] == ["ETH-Sunnyday", "KITTI-13", "KITTI-17", "PETS09-S2L1", "TUD-Campus",
                                     "TUD-Stadtmitte", "Venice-2"]
    assert all(s.dets_path.name == "det.txt" and s.object_class == "pedestrian" for s in acf)
    kitti17 = io.load_detections(acf[2])  # det.txt of KITTI-17: 552 lines (PROVENANCE.md)
    assert kitti17.num_detections == 552 and kitti17.num_frames == 145
    cyc = benchmark_sequences("kitti-cyc", DATA)
    assert [s.name for s in cyc] == [f"{i:04d}" for i in range(21)]
    assert all(s.object_class == "cyclist" and s.dets_path.parent.name == "Cyclist" for s in cyc)
    # 0012: 78 frames; det_02_pointrcnn/Cyclist/0012.txt has 56 rows, all of type 3; label_02/0012.txt
    # has 41 Cyclist rows (one object) and no distractor class for cyclists (only Cyclist rows load)
    dets, gt = io.load_detections(cyc[12]), io.load_ground_truth(cyc[12])
    assert (dets.num_frames, dets.num_detections) == (78, 56)
    assert (gt.num_targets, len(gt.frames), int(gt.distractor.sum()), len(set(gt.ids))) == (41, 41, 0, 1)
    # nothing is tuned on them: no split to tune on instead, unlike a KITTI benchmark holding val sequences
    assert tuning_split("kitti-cyc") is None and tuning_split("mot15-acf") is None
    assert tuning_split("kitti-car-val") == "kitti-car-train"


@needs_data
def test_load_detections_and_ground_truth_of_a_benchmark_sequence():
    seq = benchmark_sequences("kitti-ped", DATA)[12]
    dets, gt = io.load_detections(seq), io.load_ground_truth(seq)
    # PROVENANCE: 0012 has 78 frames, 81 Pedestrian detections, 64 Pedestrian label rows
    assert (dets.num_frames, dets.num_detections, gt.num_targets) == (78, 81, 64)
    mot = benchmark_sequences("mot15-sort6", DATA)[5]  # KITTI-17: 145 frames, 592 dets, 782 gt lines
    assert (io.load_detections(mot).num_detections, io.load_ground_truth(mot).num_frames) == (592, 145)


@needs_data
def test_kitti_val_and_train_splits_partition_the_21_sequences_by_the_seqmap():
    # the seqmap lists 0001 0006 0008 0010 0012 0013 0014 0015 0016 0018 0019 (AB3DMOT's val split)
    val = ["0001", "0006", "0008", "0010", "0012", "0013", "0014", "0015", "0016", "0018", "0019"]
    train = ["0000", "0002", "0003", "0004", "0005", "0007", "0009", "0011", "0017", "0020"]
    for cls, det_dir in (("car", "Car"), ("ped", "Pedestrian")):
        assert [s.name for s in benchmark_sequences(f"kitti-{cls}-val", DATA)] == val
        seqs = benchmark_sequences(f"kitti-{cls}-train", DATA)
        assert [s.name for s in seqs] == train
        assert all(s.dets_path.parent.name == det_dir for s in seqs)


def test_kitti_split_follows_the_seqmap_file_not_a_fixed_list(tmp_path):
    base = tmp_path / "KITTI" / "tracking" / "training"
    for name in ("0002", "0005"):
        write(base / "det_02_pointrcnn" / "Car" / f"{name}.txt", "0,2,1,1,20,20,1.0,1,1,1,1,1,1,0,0\n")
        write(base / "label_02" / f"{name}.txt", "0 1 Car 0 0 0 1 1 20 20 1 1 1 1 1 1 0\n")
    seqmap = write(base / "evaluate_tracking.seqmap.val", "0005 empty 000000 000001\n")
    assert [s.name for s in benchmark_sequences("kitti-car-val", tmp_path)] == ["0005"]
    # the train split lists every other training sequence, so its missing files are reported
    with pytest.raises(InputFormatError, match="missing file of benchmark 'kitti-car-train'"):
        benchmark_sequences("kitti-car-train", tmp_path)
    write(seqmap, "0005 empty\n0005 empty\n")
    with raises_at(seqmap, 2, "listed twice"):
        benchmark_sequences("kitti-car-val", tmp_path)
    write(seqmap, "0042 empty\n")
    with raises_at(seqmap, 1, "not a KITTI training sequence"):
        benchmark_sequences("kitti-car-val", tmp_path)


def test_benchmark_sequences_reports_a_missing_data_root(tmp_path):
    with pytest.raises(InputFormatError, match="missing file of benchmark 'mot15'"):
        benchmark_sequences("mot15", tmp_path)
    with pytest.raises(InputFormatError, match="data root"):
        benchmark_sequences("kitti-car", tmp_path / "nowhere")
    with pytest.raises(ValueError, match="unknown benchmark"):
        benchmark_sequences("mot99", tmp_path)


def test_demo_sequence_is_bundled_and_readable():
    demo = io.demo_sequence_paths()
    assert demo.name == "TUD-Campus" and demo.format == "mot"
    dets, gt = io.load_detections(demo), io.load_ground_truth(demo)
    # TUD-Campus: 321 SORT Faster R-CNN detections, 359 gt rows, 71 frames
    assert (dets.num_detections, dets.num_frames, gt.num_targets) == (321, 71, 359)
    if (MOT15 / "TUD-Campus").is_dir():
        assert demo.dets_path.read_bytes() == (MOT15 / "TUD-Campus/det/det_sort_frcnn.txt").read_bytes()
        assert demo.gt_path.read_bytes() == (MOT15 / "TUD-Campus/gt/gt.txt").read_bytes()


# ---------------------------------------------------------------------------------------
# hand-made files: confidences, frame layout, seqinfo


def test_unit_interval_scores_map_to_round_100_times_score(tmp_path):
    p = write(tmp_path / "det.txt", "1,-1,0,0,10,10,0.997784,-1,-1,-1\n1,-1,0,0,10,10,0.5,-1,-1,-1\n"
              "3,-1,0,0,10,10,0.004,-1,-1,-1\n")
    seq = io.read_mot_detections(p, scores_rule="probability")
    # 100*0.997784 = 99.78 -> 100; 100*0.5 = 50; 100*0.004 = 0.4 -> 0
    assert seq.frames[0].confidences.tolist() == [100, 50]
    assert seq.frames[2].confidences.tolist() == [0]
    # no seqinfo: frames 1..max frame (3), frame 2 empty
    assert [len(f) for f in seq.frames] == [2, 0, 1]
    assert seq.image_size is None and seq.fps is None


def test_raw_scores_map_to_clipped_rounded_score(tmp_path):
    p = write(tmp_path / "det.txt", "1,-1,0,0,10,10,42.5,-1\n1,-1,0,0,10,10,-0.8\n1,-1,0,0,10,10,139\n"
              "1,-1,0,0,10,10,0.5,-1,-1\n")
    # --scores raw: round-half-up(42.5)=43, -0.8 -> -1 -> 0, 139 -> 100, 0.5 -> round-half-up(0.5) = 1
    assert io.read_mot_detections(p, scores_rule="raw").frames[0].confidences.tolist() == [43, 0, 100, 1]


def test_scores_of_any_scale_are_read_by_default_without_a_warning(tmp_path, recwarn):
    p = write(tmp_path / "det.txt", "1,-1,0,0,10,10,42.5,-1\n1,-1,0,0,10,10,-0.8\n1,-1,0,0,10,10,139\n"
              "1,-1,0,0,10,10,0.5,-1,-1\n2,-1,0,0,10,10,40\n")
    # three of five scores outside [0,1]: the default rule (evidence) reads any scale.  Before 20
    # detections are labelled its confidences are its prior, the bare rank never below 40
    # (EVIDENCE_FLOOR): frame 1 (n = 4, sorted -0.8 0.5 42.5 139): 42.5 has 3 <= it -> 75, -0.8 1 ->
    # 25 -> 40, 139 4 -> 100, 0.5 2 -> 50; frame 2 (n = 5): 40 has 3 <= it -> 60
    seq = io.read_mot_detections(p)
    assert [f.confidences.tolist() for f in seq.frames] == [[75, 40, 100, 50], [60]]
    # the rank rule maps the same ranks k / 4 onto 20..100 (RANK_LOW): 20 + 80 k / 4 = 80, 40, 100, 60
    assert io.read_mot_detections(p, scores_rule="rank").frames[0].confidences.tolist() == [80, 40, 100, 60]
    # frame 2: 40 third of 5 -> 20 + 80 * 3 / 5 = 68
    assert io.read_mot_detections(p, scores_rule="rank").frames[1].confidences.tolist() == [68]
    assert not [w for w in recwarn if issubclass(w.category, io.InputFormatWarning)]


def test_every_score_rule_reads_every_format(tmp_path):
    row = "0,2,10,20,110,70,{s},1.5,1.6,4.0,1.0,1.0,10.0,0.1,0.2\n"
    kitti = write(tmp_path / "Car" / "0000.txt", row.format(s="0.25") + row.format(s="0.5"))
    mot = write(tmp_path / "det.txt", "1,-1,10,20,100,50,0.25\n1,-1,10,20,100,50,0.5\n")
    # the same two scores give the same confidences in either layout, by every rule: probability
    # 25, 50; sigmoid(0.25) = 0.5622 -> 56, sigmoid(0.5) = 0.6225 -> 62; raw 0.25 -> 0, 0.5 -> 1
    # (half up); evidence (its prior, the bare rank): 1 of 2 <= 0.25 -> 50, 2 of 2 -> 100; rank maps
    # those ranks onto 20..100 (RANK_LOW): 20 + 80 / 2 = 60, 100
    expected = {"probability": [25, 50], "sigmoid": [56, 62], "raw": [0, 1], "rank": [60, 100],
                "evidence": [50, 100], "auto": [50, 100]}
    assert set(expected) == set(io.SCORE_RULES)
    for rule, conf in expected.items():
        assert io.read_kitti_detections(kitti, "car", scores_rule=rule).frames[0].confidences.tolist() == conf
        assert io.read_mot_detections(mot, scores_rule=rule).frames[0].confidences.tolist() == conf


def test_kitti_scores_map_to_round_100_sigmoid(tmp_path):
    row = "0,2,10,20,110,70,{s},1.5,1.6,4.0,1.0,1.0,10.0,0.1,0.2\n"
    p = write(tmp_path / "Car" / "0000.txt",
              row.format(s="0.0") + row.format(s="-0.4501") + row.format(s="15.5") + row.format(s="-40"))
    seq = io.read_kitti_detections(p, "car", scores_rule="sigmoid")
    # sigmoid(0) = 0.5 -> 50; 100/(1+e^0.4501) = 38.93 -> 39; sigmoid(15.5) ~ 1 -> 100; sigmoid(-40) ~ 0 -> 0
    assert seq.frames[0].confidences.tolist() == [50, 39, 100, 0]
    # x1,y1,x2,y2 = 10,20,110,70 -> xywh 10,20,100,50
    assert seq.frames[0].boxes[0].tolist() == [10, 20, 100, 50]
    assert seq.num_frames == 1  # no label_02 next to it: max frame + 1


def test_kitti_detections_keep_only_the_requested_class_and_take_length_from_labels(tmp_path):
    write(tmp_path / "label_02" / "0003.txt",
          "4 0 Car 0 0 0 10 20 110 70 1 1 1 1 1 1 0\n")  # frames 0..4
    p = write(tmp_path / "det_02_pointrcnn" / "Pedestrian" / "0003.txt",
              "1,1,0,0,5,10,1.0,1,1,1,1,1,1,1,1\n1,2,0,0,50,50,1.0,1,1,1,1,1,1,1,1\n")
    seq = io.read_kitti_detections(p, "pedestrian")
    # label frames 0..4 -> 4 + 1 = 5 frames; type 2 (car) row is filtered out
    assert seq.num_frames == 5 and seq.num_detections == 1
    assert seq.frames[1].types == ("pedestrian",)
    assert io.read_kitti_detections(p, "car", num_frames=2).num_detections == 1


def test_seqinfo_next_to_det_folder_sets_length_and_image_size(tmp_path):
    write(tmp_path / "Tiny" / "seqinfo.ini", SEQINFO.format(n=5))
    p = write(tmp_path / "Tiny" / "det" / "det.txt", "2,-1,1,2,3,4,0.9\n")
    seq = io.read_mot_detections(p)
    # seqLength 5 -> frames 1..5 (trailing frames 3..5 empty)
    assert [f.frame for f in seq.frames] == [1, 2, 3, 4, 5]
    assert [len(f) for f in seq.frames] == [0, 1, 0, 0, 0]
    assert (seq.name, seq.image_size, seq.fps) == ("Tiny", (640, 480), 25.0)
    info = io.read_seqinfo(tmp_path / "Tiny" / "seqinfo.ini")
    assert (info["name"], info["seqLength"], info["imWidth"], info["imHeight"], info["frameRate"]) == \
        ("Tiny", 5, 640, 480, 25.0)


def test_mot17_style_ground_truth_marks_targets_distractors_and_others(tmp_path):
    p = write(tmp_path / "gt.txt",
              "1,1,0,0,10,10,1,1,0.8\n"    # pedestrian, consider -> target
              "1,2,0,0,10,10,0,7,1\n"      # static person -> distractor
              "1,3,0,0,10,10,0,3,1\n"      # car -> neither
              "2,1,0,0,10,10,1,1,0.25\n"
              "1,4,0,0,10,10,0,12,1\n")    # reflection -> distractor
    gt = io.read_mot_ground_truth(p)
    # rows are sorted by (frame, id): (1,1) (1,2) (1,3) (1,4) (2,1)
    assert gt.ids.tolist() == [1, 2, 3, 4, 1]
    assert gt.considered.tolist() == [True, False, False, False, True]
    assert gt.distractor.tolist() == [False, True, False, True, False]
    assert gt.visibility.tolist() == [0.8, 1.0, 1.0, 1.0, 0.25]
    assert gt.dontcare.shape == (0, 5)


def test_kitti_ground_truth_keeps_targets_distractors_and_dontcare_regions(tmp_path):
    p = write(tmp_path / "0001.txt",
              "0 -1 DontCare -1 -1 -10 0 0 50 40 -1000 -1000 -1000 -10 -1 -1 -1\n"
              "0 0 Car 0 0 0 100 100 150 140 1 1 1 1 1 1 0\n"
              "0 1 Van 0 0 0 200 100 260 140 1 1 1 1 1 1 0\n"
              "1 2 Truck 0 0 0 10 10 20 20 1 1 1 1 1 1 0\n"
              "1 3 Pedestrian 0 0 0 10 10 20 40 1 1 1 1 1 1 0\n")
    gt = io.read_kitti_ground_truth(p, "Car")
    assert gt.ids.tolist() == [0, 1]          # Truck and Pedestrian are not loaded for car
    assert gt.considered.tolist() == [True, False]
    assert gt.distractor.tolist() == [False, True]
    # x1,y1,x2,y2 = 100,100,150,140 -> xywh 100,100,50,40; DontCare 0,0,50,40 in frame 0
    assert gt.boxes[0].tolist() == [100, 100, 50, 40]
    assert gt.dontcare.tolist() == [[0, 0, 0, 50, 40]]
    assert gt.num_frames == 2


# ---------------------------------------------------------------------------------------
# every InputFormatError case, with the exact file:line


GOOD_DET = "1,-1,0,0,10,10,0.9,-1,-1,-1\n"


def test_missing_file_is_an_input_format_error(tmp_path):
    p = tmp_path / "nope.txt"
    with raises_at(p, None, "file not found"):
        io.read_mot_detections(p)
    with raises_at(p, None, "file not found"):
        io.read_seqinfo(p)


def test_empty_file_is_an_input_format_error(tmp_path):
    p = write(tmp_path / "det.txt", "\n  \n")
    with raises_at(p, None, "empty file"):
        io.read_mot_detections(p)
    with raises_at(p, None, "empty file"):
        io.read_mot_results(p)
    assert io.read_mot_results(p, allow_empty=True).shape == (0, 6)


def test_unreadable_file_is_an_input_format_error(tmp_path):
    p = write(tmp_path / "det.txt", b"\xff\xfe\x00\x81garbage")
    with raises_at(p, None, "not a UTF-8 text file"):
        io.read_mot_detections(p)
    d = tmp_path / "adir"
    d.mkdir()
    with raises_at(d, None, "is a directory"):
        io.read_kitti_ground_truth(d, "car")


def test_wrong_column_count_names_the_line(tmp_path):
    p = write(tmp_path / "det.txt", GOOD_DET + "\n" + "2,-1,0,0,10\n")
    with raises_at(p, 3, "expected 7 to 10 comma-separated fields"):
        io.read_mot_detections(p)
    k = write(tmp_path / "label.txt", "0 0 Car 0 0 0 1 1 5 5 1 1 1 1 1 1\n")
    with raises_at(k, 1, "expected 17 space-separated fields"):
        io.read_kitti_ground_truth(k, "car")


def test_non_numeric_field_names_the_line_and_field(tmp_path):
    p = write(tmp_path / "det.txt", GOOD_DET + "2,-1,abc,0,10,10,0.9\n")
    with raises_at(p, 2, "field 3 (x) is not a number: 'abc'"):
        io.read_mot_detections(p)


def test_nan_and_inf_are_rejected(tmp_path):
    p = write(tmp_path / "det.txt", GOOD_DET + "2,-1,0,0,10,10,nan\n")
    with raises_at(p, 2, "field 7 (score) is not finite"):
        io.read_mot_detections(p)
    q = write(tmp_path / "res.txt", "1,1,0,0,10,10\n1,2,0,-inf,10,10\n")
    with raises_at(q, 2, "field 4 (y) is not finite"):
        io.read_mot_results(q)


def test_non_positive_width_or_height_is_rejected(tmp_path):
    p = write(tmp_path / "det.txt", GOOD_DET + "2,-1,0,0,0,10,0.9\n")
    with raises_at(p, 2, "width and height must be > 0"):
        io.read_mot_detections(p)
    g = write(tmp_path / "gt.txt", "1,1,0,0,10,10,1,1,1\n1,2,0,0,10,-3,1,1,1\n")
    with raises_at(g, 2, "width and height must be > 0"):
        io.read_mot_ground_truth(g)


def test_kitti_negative_box_is_an_error_and_zero_box_is_recorded_or_an_error(tmp_path):
    row = "0,2,{x1},20,{x2},70,1.0,1,1,1,1,1,1,1,1\n"
    neg = write(tmp_path / "a" / "0000.txt", row.format(x1=10, x2=110) + row.format(x1=50, x2=40))
    with raises_at(neg, 2, "negative size"):
        io.read_kitti_detections(neg, "car")
    zero = write(tmp_path / "b" / "0000.txt", row.format(x1=10, x2=110) + row.format(x1=40, x2=40))
    with raises_at(zero, 2, "width and height must be > 0"):
        io.read_kitti_detections(zero, "car", on_degenerate="error")
    with pytest.warns(InputFormatWarning):
        seq = io.read_kitti_detections(zero, "car")
    assert seq.num_detections == 1 and seq.dropped == ((2, "zero-area box w=0 h=50"),)


def test_frame_before_the_first_frame_is_rejected(tmp_path):
    p = write(tmp_path / "det.txt", GOOD_DET + "0,-1,0,0,10,10,0.9\n")
    with raises_at(p, 2, "frame 0 is before the first frame 1"):
        io.read_mot_detections(p)
    k = write(tmp_path / "l.txt", "-1 0 Car 0 0 0 1 1 5 5 1 1 1 1 1 1 0\n")
    with raises_at(k, 1, "frame -1 is before the first frame 0"):
        io.read_kitti_ground_truth(k, "car")


def test_fractional_frame_and_frame_beyond_seq_length_are_rejected(tmp_path):
    p = write(tmp_path / "det.txt", "1.5,-1,0,0,10,10,0.9\n")
    with raises_at(p, 1, "frame is not an integer: 1.5"):
        io.read_mot_detections(p)
    write(tmp_path / "S" / "seqinfo.ini", SEQINFO.format(n=3))
    q = write(tmp_path / "S" / "det" / "det.txt", GOOD_DET + "4,-1,0,0,10,10,0.9\n")
    with raises_at(q, 2, "frame 4 is after the last frame 3"):
        io.read_mot_detections(q)
    typo = write(tmp_path / "typo.txt", GOOD_DET + "10000000001,-1,0,0,10,10,0.9\n")
    with raises_at(typo, 2, "implausibly large frame number"):
        io.read_mot_detections(typo)


def test_duplicate_frame_id_in_ground_truth_and_results_is_rejected(tmp_path):
    g = write(tmp_path / "gt.txt", "1,1,0,0,10,10,1,1,1\n1,2,0,0,10,10,1,1,1\n1,1,5,5,10,10,1,1,1\n")
    with raises_at(g, 3, "duplicate (frame 1, id 1); first seen on line 1"):
        io.read_mot_ground_truth(g)
    r = write(tmp_path / "res.txt", "2,7,0,0,10,10,1,-1,-1,-1\n2,7,1,1,10,10,1,-1,-1,-1\n")
    with raises_at(r, 2, "duplicate (frame 2, id 7)"):
        io.read_mot_results(r)
    k = write(tmp_path / "l.txt", "0 3 Car 0 0 0 1 1 5 5 1 1 1 1 1 1 0\n0 3 Van 0 0 0 1 1 5 5 1 1 1 1 1 1 0\n")
    with raises_at(k, 2, "duplicate (frame 0, id 3)"):
        io.read_kitti_ground_truth(k, "car")


def test_unknown_class_names_are_rejected(tmp_path):
    k = write(tmp_path / "l.txt", "0 3 Car 0 0 0 1 1 5 5 1 1 1 1 1 1 0\n0 4 Bus 0 0 0 1 1 5 5 1 1 1 1 1 1 0\n")
    with raises_at(k, 2, "unknown object type 'Bus'"):
        io.read_kitti_ground_truth(k, "car")
    with raises_at(k, None, "unknown object class 'truck'"):
        io.read_kitti_ground_truth(k, "truck")
    g = write(tmp_path / "gt.txt", "1,1,0,0,10,10,1,14,1\n")
    with raises_at(g, 1, "unknown class 14"):
        io.read_mot_ground_truth(g)
    d = write(tmp_path / "d" / "0000.txt", "0,4,0,0,5,5,1,1,1,1,1,1,1,1,1\n")
    with raises_at(d, 1, "unknown class type 4"):
        io.read_kitti_detections(d, "car")


def test_mixed_ground_truth_layouts_are_rejected(tmp_path):
    g = write(tmp_path / "gt.txt", "1,1,0,0,10,10,1,1,1\n2,1,0,0,10,10,1,-1,-1,-1\n")
    with raises_at(g, 2, "mixed field counts"):
        io.read_mot_ground_truth(g)


def test_bad_seqinfo_values_are_rejected(tmp_path):
    p = write(tmp_path / "seqinfo.ini", SEQINFO.format(n="many"))
    with raises_at(p, 5, "seqLength is not an integer: 'many'"):
        io.read_seqinfo(p)
    q = write(tmp_path / "b.ini", "[Sequence]\nname=X\n")
    with raises_at(q, None, "missing key 'frameRate'"):
        io.read_seqinfo(q)
    r = write(tmp_path / "c.ini", "name=X\n")
    with raises_at(r, None, "not a valid seqinfo.ini"):
        io.read_seqinfo(r)
    # a frame rate the presets' conversions cannot reach (refimpl.core.ranges.FPS_MIN..FPS_MAX):
    # at 0.01 fps the KITTI Car preset's velocity noise would be 10 * (10 / 0.01) ** 2 = 10^7
    for rate in ("0.01", "5000"):
        s = write(tmp_path / "d.ini", SEQINFO.format(n=10).replace("frameRate=25", f"frameRate={rate}"))
        with raises_at(s, 4, f"frameRate must be a frame rate from 0.1 to 1000 frames per second, got '{rate}'"):
            io.read_seqinfo(s)


def test_input_format_error_is_a_picklable_value_error():
    err = InputFormatError("bad", "/x/y.txt", 3)
    assert isinstance(err, ValueError) and str(err) == "/x/y.txt:3: bad"
    again = pickle.loads(pickle.dumps(err))
    assert (str(again), again.line, again.path, again.reason) == (str(err), 3, "/x/y.txt", "bad")


# ---------------------------------------------------------------------------------------
# results: atomic, sorted writing and reading back


def test_write_mot_results_sorts_formats_and_reads_back(tmp_path):
    out = tmp_path / "sub" / "res.txt"
    rows = np.array([[2, 5, 1.004, 2.0, 3.0, 4.0],
                     [1, 9, -0.001, 0.5, 10.0, 20.0],
                     [1, 3, 7.126, 8.0, 9.0, 10.0]])
    io.write_mot_results(out, rows)
    # sorted by (frame, id): (1,3) (1,9) (2,5); -0.001 prints as 0.00, 7.126 as 7.13
    assert out.read_text() == ("1,3,7.13,8.00,9.00,10.00,1,-1,-1,-1\n"
                               "1,9,0.00,0.50,10.00,20.00,1,-1,-1,-1\n"
                               "2,5,1.00,2.00,3.00,4.00,1,-1,-1,-1\n")
    back = io.read_mot_results(out)
    assert back.tolist() == [[1, 3, 7.13, 8, 9, 10], [1, 9, 0, 0.5, 10, 20], [2, 5, 1, 2, 3, 4]]
    assert os.listdir(out.parent) == ["res.txt"]  # no temporary file left behind


def test_write_mot_results_never_leaves_a_partial_file(tmp_path, monkeypatch):
    out = tmp_path / "res.txt"
    io.write_mot_results(out, [[1, 1, 0, 0, 5, 5]])
    before = out.read_text()
    with pytest.raises(ValueError, match="duplicate"):
        io.write_mot_results(out, [[1, 1, 0, 0, 5, 5], [1, 1, 2, 2, 5, 5]])
    with pytest.raises(ValueError, match="width and height"):
        io.write_mot_results(out, [[1, 1, 0, 0, 0.001, 5]])

    def crash(src, dst):
        raise OSError("disk gone")

    monkeypatch.setattr(os, "replace", crash)
    with pytest.raises(OSError, match="disk gone"):
        io.write_mot_results(out, [[1, 2, 0, 0, 5, 5]])
    assert out.read_text() == before
    assert os.listdir(tmp_path) == ["res.txt"]


def test_kitti_results_keep_0_based_frames_when_asked(tmp_path):
    out = tmp_path / "kitti.txt"
    with pytest.raises(ValueError, match="first_frame=0"):
        io.write_mot_results(out, [[0, 1, 0, 0, 5, 5]])
    io.write_mot_results(out, [[0, 1, 0, 0, 5, 5]], first_frame=0)
    with raises_at(out, 1, "frame 0 is before the first frame 1"):
        io.read_mot_results(out)
    assert io.read_mot_results(out, first_frame=0).tolist() == [[0, 1, 0, 0, 5, 5]]


def test_write_mot_results_accepts_no_rows(tmp_path):
    out = tmp_path / "res.txt"
    io.write_mot_results(out, np.zeros((0, 6)))
    assert out.read_text() == ""
    assert io.read_mot_results(out, allow_empty=True).shape == (0, 6)
