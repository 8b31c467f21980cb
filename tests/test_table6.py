"""refimpl table6's text: the paper's Table 6 shape, and the ID switches' change (the paper's headline)
reported apart from the fragmentations."""

from __future__ import annotations

from refimpl.experiments.table6 import PAPER_ID_SWITCHES, BenchmarkRun, change, format_table6


def _overall(idsw: int, frag: int, mota: float) -> dict:
    return {"hota": 0.5, "deta": 0.5, "assa": 0.5, "mota": mota, "motp": 0.8, "idf1": 0.6, "mt": 10, "ml": 5,
            "fp": 100, "fn": 200, "idsw": idsw, "frag": frag, "num_unique_objects": 40}


def test_change_is_the_relative_change_of_a_count():
    # the paper's Table 6, KITTI cars: (165 - 1097) / 1097 = -0.8496 -> -85.0 %; MOT 2017: (800 - 779) / 779 = +2.7 %
    assert change(1097, 165) == "1097 -> 165 (-85.0 %)"
    assert change(779, 800) == "779 -> 800 (+2.7 %)"
    assert change(0, 0) == "0 -> 0" and change(0, 4) == "0 -> 4 (from none)"  # no percentage of nothing


def test_table6_reports_id_switches_and_fragmentations_apart_with_the_papers_beside():
    base = BenchmarkRun("kitti-car", "baseline", {}, _overall(200, 246, 0.70), {}, 8008, 1.0)
    abd = BenchmarkRun("kitti-car", "cpsat", {}, _overall(50, 171, 0.75), {"recover": 3, "noise": 7}, 8008, 1.0)
    text = format_table6([(base, abd)])
    lines = text.splitlines()
    row = next(line for line in lines if line.startswith("| with abduction (cpsat)"))
    assert row.endswith("| 50 | 171 |")  # ID sw. and Frag. in their own columns
    verdict = next(line for line in lines if line.startswith("MOTA "))
    # ID sw. 200 -> 50 is -75.0 %; Frag. 246 -> 171 is -75 / 246 = -30.5 %; IDs + Frag. (446 -> 221) is not summed
    assert "ID sw. 200 -> 50 (-75.0 %); Frag. 246 -> 171 (-30.5 %)" in verdict and "446" not in verdict
    assert "the paper (KITTI tracking, Cars, YOLOv3 detections): ID sw. 1097 -> 165 (-85.0 %)" in verdict
    assert verdict.endswith("Events abduced: noise 7, recover 3.")
    # a dataset without a row of the paper's table gets no paper comparison
    mot = [BenchmarkRun("mot15", t, {}, o, {}, 5500, 1.0) for t, o in (("baseline", _overall(547, 900, 0.4)),
                                                                       ("cpsat", _overall(329, 800, 0.42)))]
    assert "mot15" not in PAPER_ID_SWITCHES and "the paper" not in format_table6([tuple(mot)])
    assert "ID sw. 547 -> 329 (-39.9 %)" in format_table6([tuple(mot)])
