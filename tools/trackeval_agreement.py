"""refimpl's scores of a results folder next to TrackEval's own MOTChallenge pipeline on the same files.

    python tools/trackeval_agreement.py [--benchmark mot15|mot17-sim|kitti-car|kitti-ped] [--tracker baseline]
                                        [--data ../shared/data]

Tracks every sequence of the benchmark, writes one MOTChallenge results file per sequence into a
temporary TrackEval tracker folder, scores the folder with refimpl (``folder_eval.evaluate_folder``,
what ``refimpl eval DIR --gt ROOT`` runs) and with ``trackeval.Evaluator`` +
``trackeval.datasets.MotChallenge2DBox`` (HOTA, CLEAR, Identity) on the ground-truth folder of
the shared data, and prints a markdown table of HOTA, MOTA and IDF1 from both.  For
``mot17-sim`` (simulated detections) a box 1 px beside every non-target ground-truth row is added
to each results file, so that the distractor preprocessing of both sides is exercised.
``kitti-car`` / ``kitti-ped``: the 11 sequences of ``evaluate_tracking.seqmap.val``, results in
the KITTI tracking format, TrackEval's ``Kitti2DBox`` (which, unlike refimpl, also ignores
truncated / occluded targets and unmatched boxes up to 25 px high: the numbers differ by design).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

from refimpl import io
from refimpl.folder_eval import evaluate_folder
from refimpl.datasets import load_dataset
from refimpl.table6 import run_tracker

MOT17_VARIANT = "FRCNN"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--benchmark", choices=("mot15", "mot17-sim", "kitti-car", "kitti-ped"), default="mot15")
    p.add_argument("--tracker", default="baseline", help="baseline, cpsat or clingo (default baseline)")
    p.add_argument("--data", default="../shared/data")
    args = p.parse_args(argv)
    import trackeval

    data = Path(args.data)
    if args.benchmark.startswith("kitti"):
        return _kitti(args, data, trackeval)
    gt_root, split = (data / "MOT15" / "train", "MOT15") if args.benchmark == "mot15" else (data / "MOT17" / "train", "MOT17")
    with tempfile.TemporaryDirectory() as tmp:
        results = Path(tmp) / "refimpl" / "data"
        seqs = []
        for name, dets, gt in load_dataset(args.benchmark, args.data):
            rows, _ = run_tracker(dets, args.tracker)
            folder = name if args.benchmark == "mot15" else f"{name}-{MOT17_VARIANT}"
            if args.benchmark == "mot17-sim":
                other = np.flatnonzero(~gt.considered)
                rows = np.vstack([rows, np.column_stack([gt.frames[other], 100_000 + gt.ids[other],
                                                         gt.boxes[other, 0] + 1, gt.boxes[other, 1:]])])
            io.write_mot_results(results / f"{folder}.txt", rows)
            seqs.append(folder)
            print(f"tracked {folder}", file=sys.stderr)
        ours = evaluate_folder(results, gt_root, "mot")
        evaluator = trackeval.Evaluator({
            "USE_PARALLEL": False, "PRINT_RESULTS": False, "PRINT_CONFIG": False, "OUTPUT_SUMMARY": False,
            "OUTPUT_DETAILED": False, "PLOT_CURVES": False, "TIME_PROGRESS": False, "DISPLAY_LESS_PROGRESS": True})
        dataset = trackeval.datasets.MotChallenge2DBox({
            "GT_FOLDER": str(gt_root), "TRACKERS_FOLDER": tmp, "OUTPUT_FOLDER": str(Path(tmp) / "out"),
            "BENCHMARK": split, "SKIP_SPLIT_FOL": True, "SEQ_INFO": {s: None for s in seqs},
            "TRACKERS_TO_EVAL": ["refimpl"], "PRINT_CONFIG": False})
        res, _ = evaluator.evaluate([dataset], [trackeval.metrics.HOTA(), trackeval.metrics.CLEAR(),
                                                trackeval.metrics.Identity()])
    theirs = res["MotChallenge2DBox"]["refimpl"]
    print(f"\n{args.benchmark}, {args.tracker} tracker: refimpl eval vs TrackEval's MotChallenge2DBox pipeline\n")
    print("| Sequence | HOTA refimpl | HOTA TrackEval | MOTA refimpl | MOTA TrackEval | IDF1 refimpl | IDF1 TrackEval |"
          " removed distractor hits |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    worst = dict.fromkeys(("HOTA", "MOTA", "IDF1"), 0.0)
    for seq in seqs + ["COMBINED_SEQ"]:
        mine = ours.overall if seq == "COMBINED_SEQ" else ours.per_sequence[seq]
        te = theirs[seq]["pedestrian"]
        pairs = {"HOTA": (mine["hota"], float(np.mean(te["HOTA"]["HOTA"]))),
                 "MOTA": (mine["mota"], float(te["CLEAR"]["MOTA"])),
                 "IDF1": (mine["idf1"], float(te["Identity"]["IDF1"]))}
        for k, (a, b) in pairs.items():
            worst[k] = max(worst[k], abs(a - b))
        cells = " | ".join(f"{100 * a:.3f} | {100 * b:.3f}" for a, b in pairs.values())
        print(f"| {'OVERALL' if seq == 'COMBINED_SEQ' else seq} | {cells} | {mine['removed_distractor']} |")
    print("\nlargest difference (points): " + ", ".join(f"{k} {100 * v:.4f}" for k, v in worst.items()))
    return 0


def _kitti(args, data: Path, trackeval) -> int:
    gt_root = data / "KITTI" / "tracking" / "training"
    cls = {"kitti-car": "car", "kitti-ped": "pedestrian"}[args.benchmark]
    val = [line.split()[0] for line in (gt_root / "evaluate_tracking.seqmap.val").read_text().splitlines() if line.strip()]
    with tempfile.TemporaryDirectory() as tmp:
        results = Path(tmp) / "refimpl" / "data"
        for name, dets, gt in load_dataset(args.benchmark, args.data):
            if name in val:
                rows, _ = run_tracker(dets, args.tracker)
                io.write_kitti_results(results / f"{name}.txt", rows, cls)
                print(f"tracked {name}", file=sys.stderr)
        ours = evaluate_folder(results, gt_root, "kitti", cls)
        evaluator = trackeval.Evaluator({
            "USE_PARALLEL": False, "PRINT_RESULTS": False, "PRINT_CONFIG": False, "OUTPUT_SUMMARY": False,
            "OUTPUT_DETAILED": False, "PLOT_CURVES": False, "TIME_PROGRESS": False, "DISPLAY_LESS_PROGRESS": True})
        dataset = trackeval.datasets.Kitti2DBox({
            "GT_FOLDER": str(gt_root), "TRACKERS_FOLDER": tmp, "OUTPUT_FOLDER": str(Path(tmp) / "out"),
            "SPLIT_TO_EVAL": "val", "CLASSES_TO_EVAL": [cls], "TRACKERS_TO_EVAL": ["refimpl"], "PRINT_CONFIG": False})
        res, _ = evaluator.evaluate([dataset], [trackeval.metrics.HOTA(), trackeval.metrics.CLEAR(),
                                                trackeval.metrics.Identity()])
    te = res["Kitti2DBox"]["refimpl"]["COMBINED_SEQ"][cls]
    o = ours.overall
    print(f"\n{args.benchmark} val (11 sequences), {args.tracker} tracker, overall: refimpl eval vs TrackEval's "
          "Kitti2DBox pipeline\n")
    print("| evaluator | HOTA | DetA | AssA | MOTA | IDF1 |\n|---|---:|---:|---:|---:|---:|")
    print(f"| refimpl eval | {100 * o['hota']:.2f} | {100 * o['deta']:.2f} | {100 * o['assa']:.2f} "
          f"| {100 * o['mota']:.2f} | {100 * o['idf1']:.2f} |")
    print(f"| TrackEval Kitti2DBox | {100 * np.mean(te['HOTA']['HOTA']):.2f} | {100 * np.mean(te['HOTA']['DetA']):.2f} "
          f"| {100 * np.mean(te['HOTA']['AssA']):.2f} | {100 * te['CLEAR']['MOTA']:.2f} | {100 * te['Identity']['IDF1']:.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
