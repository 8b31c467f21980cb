"""refimpl sweep: the grid, KITTI's tuning / validation split, the table; progress stays off stdout."""

from __future__ import annotations

import contextlib
import io as stdio
import math

import pytest

from refimpl import cli, io
from refimpl.runs.scaleout import Plan
from refimpl.experiments.sweep import SweepPlan, format_sweep, grid_settings, run_sweep, split_dataset, val_sequences
from refimpl.experiments.benchmark_tasks import RunRequest, RunSummary


def run_cli(argv, stderr=None):
    out, err = stdio.StringIO(), stderr or stdio.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = cli.main(argv)
    return code, out.getvalue(), err.getvalue()


def test_grid_is_every_combination_first_constant_slowest():
    names, settings = grid_settings([("conf_thresh_new_track", (30, 40)), ("iou_thresh", (20000, 30000, 40000))])
    assert names == ("conf_thresh_new_track", "iou_thresh")
    assert settings == ((30, 20000), (30, 30000), (30, 40000), (40, 20000), (40, 30000), (40, 40000))


@pytest.mark.parametrize("grid, message", [
    ([("iou_treshold", (1,))], "unknown model constant 'iou_treshold'"),
    ([("img_width", (640,))], "set per sequence"),
    ([("iou_thresh", (1,)), ("iou_thresh", (2,))], "two --grid"),
])
def test_bad_grids(grid, message):
    with pytest.raises(ValueError, match=message):
        grid_settings(grid)


def test_kitti_split_follows_seqmap_val(shared_data):
    # evaluate_tracking.seqmap.val lists 0001 0006 0008 0010 0012 0013 0014 0015 0016 0018 0019
    assert val_sequences(shared_data) == ("0001", "0006", "0008", "0010", "0012", "0013", "0014", "0015",
                                          "0016", "0018", "0019")
    dataset = [(f"{i:04d}", None, None) for i in range(21)]
    tune = [n for n, _, _ in split_dataset("kitti-car", dataset, shared_data, "tune")]
    assert tune == ["0000", "0002", "0003", "0004", "0005", "0007", "0009", "0011", "0017", "0020"]
    assert len(split_dataset("kitti-car", dataset, shared_data, "val")) == 11
    with pytest.raises(ValueError, match="KITTI benchmarks only"):
        split_dataset("mot15", dataset, shared_data, "tune")


def test_sweep_on_the_demo_sequence():
    seq = io.demo_sequence_paths()
    data = [(seq.name, io.load_detections(seq), io.load_ground_truth(seq))]
    names, settings = grid_settings([("conf_thresh_new_track", (40, 101))])
    requests = tuple(RunRequest("demo", data, "cpsat", tuple(zip(names, v))) for v in settings)
    result = run_sweep(SweepPlan(names, settings, "demo", "all", (seq.name,), "cpsat", requests), Plan(), quiet=True)
    default, never = (r.overall for r in result.runs)
    # 101 > every confidence (0..100): no track ever starts, so no predictions: FN = num_gt, FP = 0,
    # MOTA = 1 - FN / num_gt = 0, IDF1 = 2*0 / (0 + 0 + IDFN) = 0, and HOTA = 0 (DetA = TP / (TP +
    # FN + FP) = 0 at every alpha)
    assert never["num_predictions"] == 0 and never["fn"] == never["num_gt"] > 0 and never["fp"] == 0
    assert never["mota"] == 0.0 and never["idf1"] == 0.0 and never["hota"] == 0.0
    assert default["num_predictions"] > 0 and default["mota"] > 0.5
    table = format_sweep(result).splitlines()
    assert table[2] == "| conf_thresh_new_track | HOTA | MOTA | IDF1 | IDs | FP | FN |"
    assert table[5] == f"| 101 | 0.0 | 0.0 | 0.0 | 0 | 0 | {never['fn']} |"


def test_table_has_no_hota_column_without_hota():
    from refimpl.experiments.sweep import SweepResult
    o = {"mota": 0.6, "idf1": 0.5, "idsw": 3, "fp": 4, "fn": 5}
    plan = SweepPlan(("iou_thresh",), ((30000,),), "b", "all", ("s",), "cpsat", ())
    result = SweepResult(plan, (RunSummary({}, o),))
    assert format_sweep(result).splitlines()[2] == "| iou_thresh | MOTA | IDF1 | IDs | FP | FN |"


def test_table_shows_hota_when_the_evaluation_has_it():
    from refimpl.experiments.sweep import SweepResult
    o = {"hota": 0.5234, "mota": 0.6, "idf1": math.nan, "idsw": 3, "fp": 4, "fn": 5}
    plan = SweepPlan(("iou_thresh",), ((30000,),), "b", "all", ("s",), "cpsat", ())
    result = SweepResult(plan, (RunSummary({}, o),))
    lines = format_sweep(result).splitlines()
    assert lines[2] == "| iou_thresh | HOTA | MOTA | IDF1 | IDs | FP | FN |"
    assert lines[4] == "| 30000 | 52.3 | 60.0 | - | 3 | 4 | 5 |"


def test_sweep_mistakes_are_one_line(shared_data):
    code, out, err = run_cli(["sweep", "--benchmark", "mot15", "--grid", "nope=1,2", "--data", str(shared_data)])
    assert code == 2 and out == "" and err.count("\n") == 1 and "unknown model constant 'nope'" in err
    code, _, err = run_cli(["sweep", "--benchmark", "mot15", "--grid", "iou_thresh=1", "--split", "val",
                            "--data", str(shared_data)])
    assert code == 2 and "KITTI benchmarks only" in err


class _Terminal(stdio.StringIO):
    def isatty(self) -> bool:
        return True


def test_progress_goes_to_a_terminal_stderr_only(tmp_path):
    det = str(io.demo_sequence_paths().dets_path)
    # stderr a terminal: a per-frame bar there (71 frames), stdout holds the one result line only
    code, out, err = run_cli(["track", "--backend", "cpsat", "--dets", det, "--out", str(tmp_path / "a.txt")],
                             stderr=_Terminal())
    assert code == 0
    # seqinfo.ini: seqLength=71; one line, the summary, nothing of the bar
    assert out.count("\n") == 1 and out.startswith("TUD-Campus: 71 frames, ")
    assert out.endswith(f" tracks -> {tmp_path / 'a.txt'}\n")
    assert "71/71" in err and "frame" in err
    # --quiet: nothing on stderr; stderr not a terminal: no bar, only the note of what ran
    assert run_cli(["track", "--backend", "cpsat", "--dets", det, "--out", str(tmp_path / "b.txt"), "--quiet"],
                   stderr=_Terminal())[2] == ""
    assert run_cli(["track", "--backend", "cpsat", "--dets", det, "--out", str(tmp_path / "c.txt")])[2] == \
        "refimpl track: note: cpsat, preset mot/pedestrian, frame budget 25 ms\n"
