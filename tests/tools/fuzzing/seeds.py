"""The valid seed files every fuzz input starts from: the fact files of data/examples, the bundled
TUD-Campus det.txt / gt.txt, a few lines of KITTI label_02 and PointRCNN files from the shared data
(hand-written samples when that folder is absent), and results files derived from them."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[3]
SHARED = Path(os.environ.get("REFIMPL_DATA_ROOT", str(REPO.parent / "shared" / "data")))
KITTI_TRAIN = SHARED / "KITTI" / "tracking" / "training"


_KITTI_DET_SAMPLE = """\
0,2,298.3125,165.1800,458.2292,293.4391,8.2981,1.9605,1.8137,4.7549,-4.5720,1.8435,13.5308,-2.1125,-1.7867
0,2,1050.4751,177.0771,1241.0000,239.3750,1.3104,1.4905,1.6289,4.0662,13.6684,1.6046,18.4125,-0.1005,-0.7391
0,1,364.7274,137.8874,453.8243,172.5940,-0.4501,1.4779,1.5952,3.8674,-9.0942,-0.0122,32.8211,-1.0285,-0.7582
1,2,296.1,166.2,455.0,292.0,8.1,1.96,1.81,4.75,-4.57,1.84,13.53,-2.11,-1.78
1,2,1051.0,177.0,1241.0,239.0,1.2,1.49,1.62,4.06,13.66,1.60,18.41,-0.10,-0.73
2,2,294.0,167.0,452.0,291.0,7.9,1.96,1.81,4.75,-4.57,1.84,13.53,-2.11,-1.78
2,3,600.0,170.0,640.0,250.0,0.3,1.7,0.6,1.8,1.0,1.6,20.0,0.1,0.05
3,2,292.0,168.0,450.0,290.0,7.7,1.96,1.81,4.75,-4.57,1.84,13.53,-2.11,-1.78
"""

_KITTI_LABEL_SAMPLE = """\
0 -1 DontCare -1 -1 -10.000000 219.310000 188.490000 245.500000 218.560000 -1000.000000 -1000.000000 -1000.000000 -10.000000 -1.000000 -1.000000 -1.000000
0 0 Van 0 0 -1.793451 296.744956 161.752147 455.226042 292.372804 2.000000 1.823255 4.433886 -4.552284 1.858523 13.410495 -2.115488
0 1 Car 0 0 -1.2 1050.0 177.0 1241.0 239.0 1.5 1.6 4.0 13.6 1.6 18.4 -0.1
0 2 Pedestrian 0 0 -0.2 600.0 170.0 640.0 250.0 1.7 0.6 0.8 1.0 1.6 20.0 0.1
1 0 Van 0 0 -1.79 295.0 162.0 453.0 291.0 2.0 1.82 4.43 -4.55 1.85 13.41 -2.11
1 1 Car 0 0 -1.2 1051.0 177.0 1241.0 239.0 1.5 1.6 4.0 13.6 1.6 18.4 -0.1
2 1 Car 1 1 -1.2 1052.0 177.0 1241.0 239.0 1.5 1.6 4.0 13.6 1.6 18.4 -0.1
2 3 Cyclist 0 2 0.5 700.0 180.0 730.0 240.0 1.7 0.6 1.8 2.0 1.6 22.0 0.1
"""

_FACTS_SAMPLE = """\
#const curr_time=12.
#const iou_thresh=20000.
det(det_0, car, 90).
det(det_1, car, 40).
box2d(det_0, 10, 20, 30, 40).
box2d(det_1, -5, 0, 8, 9).
trk(trk_3, car).
trk_state(trk_3, active).
trk(trk_4, car).
trk_state(trk_4, halted).
box2d(trk_3, 11, 21, 30, 40).
box2d(trk_4, 100, 100, 20, 20).
iou(trk_3,det_0,87000).
match_type(car, truck).
occurs_at(hides_behind(trk_4,trk_3),9).
occurs_at(missing_detections(trk_4),11).
"""


def _head(path: Path, n: int) -> str | None:
    try:
        with open(path, encoding="utf-8") as fh:
            lines = [next(fh) for _ in range(n)]
    except (OSError, StopIteration, UnicodeDecodeError):
        return None
    return "".join(lines)


def _mot_results_from_gt(text: str) -> str:
    out = []
    for line in text.splitlines()[:120]:
        f = line.split(",")
        out.append(",".join(f[:6]) + ",1,-1,-1,-1\n")
    return "".join(out)


def _kitti_results_from_label(text: str) -> str:
    out = []
    for line in text.splitlines():
        f = line.split()
        if f[2] not in ("Car", "Van", "Pedestrian", "Cyclist"):
            continue
        x1, y1, x2, y2 = (float(v) for v in f[6:10])
        out.append(f"{f[0]},{f[1]},{x1:.2f},{y1:.2f},{x2 - x1:.2f},{y2 - y1:.2f},1,-1,-1,-1\n")
    return "".join(out)


@dataclass
class Seeds:
    facts: list[tuple[str, str]]
    mot_det: list[tuple[str, str]]
    mot_gt: list[tuple[str, str]]
    mot_results: list[tuple[str, str]]
    kitti_det: list[tuple[str, str]]
    kitti_gt: list[tuple[str, str]]
    seqinfo: str
    mot_gt_path: Path
    mot_results_text: str
    kitti_label_text: str
    kitti_car_label_text: str
    kitti_results_text: str


def load_seeds() -> Seeds:
    facts = [(p.name, p.read_text(encoding="utf-8")) for p in sorted((REPO / "data" / "examples").glob("*.lp"))]
    facts.append(("sample.lp", _FACTS_SAMPLE))
    demo = REPO / "data" / "demo" / "TUD-Campus"
    det = (demo / "det" / "det.txt").read_text(encoding="utf-8")
    gt = (demo / "gt" / "gt.txt").read_text(encoding="utf-8")
    det_lines = det.splitlines(keepends=True)
    gt_lines = gt.splitlines(keepends=True)
    # MOT16-style 9-field gt (flag, class, visibility) from the MOT15 rows
    gt9 = "".join(",".join(l.split(",")[:6] + ["1", str(c), "0.75"]) + "\n"
                  for l, c in zip(gt_lines[:60], [1, 1, 2, 7, 8, 12, 3, 1, 1, 1] * 6))
    kdet = _head(KITTI_TRAIN / "det_02_pointrcnn" / "Car" / "0000.txt", 60) or _KITTI_DET_SAMPLE
    kdet_ped = _head(KITTI_TRAIN / "det_02_pointrcnn" / "Pedestrian" / "0001.txt", 40)
    klabel = _head(KITTI_TRAIN / "label_02" / "0000.txt", 60) or _KITTI_LABEL_SAMPLE  # Van, Cyclist, ...
    klabel_car = _head(KITTI_TRAIN / "label_02" / "0001.txt", 60) or _KITTI_LABEL_SAMPLE  # Car, DontCare
    kitti_det = [("0000.txt", kdet), ("sample.txt", _KITTI_DET_SAMPLE)]
    if kdet_ped:
        kitti_det.append(("ped0001.txt", kdet_ped))
    mot_results = _mot_results_from_gt(gt)
    kitti_results = _kitti_results_from_label(klabel_car)
    return Seeds(
        facts=facts,
        mot_det=[("det.txt", det), ("det_head.txt", "".join(det_lines[:40]))],
        mot_gt=[("gt.txt", gt), ("gt_head.txt", "".join(gt_lines[:50])), ("gt9.txt", gt9)],
        mot_results=[("results.txt", mot_results), ("kitti_results.txt", kitti_results)],
        kitti_det=kitti_det,
        kitti_gt=[("0000.txt", klabel), ("0001.txt", klabel_car), ("sample.txt", _KITTI_LABEL_SAMPLE)],
        seqinfo=(demo / "seqinfo.ini").read_text(encoding="utf-8"),
        mot_gt_path=demo / "gt" / "gt.txt",
        mot_results_text=mot_results,
        kitti_label_text=klabel,
        kitti_car_label_text=klabel_car,
        kitti_results_text=kitti_results,
    )
