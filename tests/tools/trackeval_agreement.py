"""refimpl's scores of a results folder next to TrackEval's own MOTChallenge pipeline on the same files.

    python tests/tools/trackeval_agreement.py [--benchmark mot15|mot17-sim|kitti-car|kitti-ped] [--tracker baseline]
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
truncated / occluded targets and unmatched boxes up to 25 px high: the numbers differ by design),
and ``refimpl eval --devkit trackeval`` (``refimpl.evaluation.devkits``), which must equal the Evaluator.

``trackeval_mot`` / ``trackeval_kitti`` run TrackEval's Evaluator directly on a layout; the tests
of ``refimpl eval --devkit trackeval`` (tests/test_eval_devkits.py) compare with them.  Run it as
``python tests/tools/trackeval_agreement.py`` from the checkout, so that this checkout's refimpl is used.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

if not __package__:  # run as a script: this checkout's refimpl first on the import path
    import _paths  # noqa: F401

import numpy as np

from refimpl import io
from refimpl.evaluation.folder_eval import evaluate_folder
from refimpl.io.datasets import load_dataset
from refimpl.experiments.table6 import run_tracker

MOT17_VARIANT = "FRCNN"


def quiet_evaluator(trackeval):
    """TrackEval's Evaluator run directly, writing no output files (it still prints two progress lines)."""
    return trackeval.Evaluator({
        "USE_PARALLEL": False, "PRINT_RESULTS": False, "PRINT_CONFIG": False, "OUTPUT_SUMMARY": False,
        "OUTPUT_DETAILED": False, "PLOT_CURVES": False, "TIME_PROGRESS": False, "DISPLAY_LESS_PROGRESS": True,
        "LOG_ON_ERROR": None})


def _metrics(trackeval):
    return [trackeval.metrics.HOTA(), trackeval.metrics.CLEAR({"PRINT_CONFIG": False}),
            trackeval.metrics.Identity({"PRINT_CONFIG": False})]


def trackeval_mot(gt_root: Path, trackers_folder: Path, seqs, benchmark: str, tracker: str = "refimpl") -> dict:
    """``Evaluator`` + ``MotChallenge2DBox`` on GT_ROOT/<seq>/{gt/gt.txt,seqinfo.ini} and
    TRACKERS_FOLDER/<tracker>/data/<seq>.txt: {seq or COMBINED_SEQ: {HOTA, CLEAR, Identity, Count}}."""
    import trackeval
    dataset = trackeval.datasets.MotChallenge2DBox({
        "GT_FOLDER": str(gt_root), "TRACKERS_FOLDER": str(trackers_folder),
        "OUTPUT_FOLDER": str(Path(trackers_folder) / "out"), "BENCHMARK": benchmark, "SKIP_SPLIT_FOL": True,
        "SEQ_INFO": {s: None for s in seqs}, "TRACKERS_TO_EVAL": [tracker], "PRINT_CONFIG": False})
    res, _ = quiet_evaluator(trackeval).evaluate([dataset], _metrics(trackeval))
    return {seq: by_class["pedestrian"] for seq, by_class in res["MotChallenge2DBox"][tracker].items()}


def trackeval_kitti(gt_root: Path, trackers_folder: Path, cls: str, split: str, tracker: str = "refimpl") -> dict:
    """``Evaluator`` + ``Kitti2DBox`` on GT_ROOT/{label_02/,evaluate_tracking.seqmap.<split>} and
    TRACKERS_FOLDER/<tracker>/data/<seq>.txt: {seq or COMBINED_SEQ: {HOTA, CLEAR, Identity, Count}}."""
    import trackeval
    dataset = trackeval.datasets.Kitti2DBox({
        "GT_FOLDER": str(gt_root), "TRACKERS_FOLDER": str(trackers_folder),
        "OUTPUT_FOLDER": str(Path(trackers_folder) / "out"), "SPLIT_TO_EVAL": split, "CLASSES_TO_EVAL": [cls],
        "TRACKERS_TO_EVAL": [tracker], "PRINT_CONFIG": False})
    res, _ = quiet_evaluator(trackeval).evaluate([dataset], _metrics(trackeval))
    return {seq: by_class[cls] for seq, by_class in res["Kitti2DBox"][tracker].items()}


def headline(te: dict) -> dict[str, float]:
    """HOTA, DetA, AssA, MOTA, IDF1 (fractions) of one entry of trackeval_mot / trackeval_kitti."""
    return {"HOTA": float(np.mean(te["HOTA"]["HOTA"])), "DetA": float(np.mean(te["HOTA"]["DetA"])),
            "AssA": float(np.mean(te["HOTA"]["AssA"])), "MOTA": float(te["CLEAR"]["MOTA"]),
            "IDF1": float(te["Identity"]["IDF1"])}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--benchmark", choices=("mot15", "mot17-sim", "kitti-car", "kitti-ped"), default="mot15")
    p.add_argument("--tracker", default="baseline", help="baseline, cpsat or clingo (default baseline)")
    p.add_argument("--data", default="../shared/data")
    args = p.parse_args(argv)

    data = Path(args.data)
    if args.benchmark.startswith("kitti"):
        return _kitti(args, data)
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
        theirs = trackeval_mot(gt_root, Path(tmp), seqs, split)
    print(f"\n{args.benchmark}, {args.tracker} tracker: refimpl eval vs TrackEval's MotChallenge2DBox pipeline\n")
    print("| Sequence | HOTA refimpl | HOTA TrackEval | MOTA refimpl | MOTA TrackEval | IDF1 refimpl | IDF1 TrackEval |"
          " removed distractor hits |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    worst = dict.fromkeys(("HOTA", "MOTA", "IDF1"), 0.0)
    for seq in seqs + ["COMBINED_SEQ"]:
        mine = ours.overall if seq == "COMBINED_SEQ" else ours.per_sequence[seq]
        te = headline(theirs[seq])
        pairs = {k: (mine[k.lower()], te[k]) for k in ("HOTA", "MOTA", "IDF1")}
        for k, (a, b) in pairs.items():
            worst[k] = max(worst[k], abs(a - b))
        cells = " | ".join(f"{100 * a:.3f} | {100 * b:.3f}" for a, b in pairs.values())
        print(f"| {'OVERALL' if seq == 'COMBINED_SEQ' else seq} | {cells} | {mine['removed_distractor']} |")
    print("\nlargest difference (points): " + ", ".join(f"{k} {100 * v:.4f}" for k, v in worst.items()))
    return 0


def _kitti(args, data: Path) -> int:
    from refimpl.evaluation.devkits import TRACKEVAL, evaluate_sequences
    from refimpl.evaluation.folder_eval import load_folder
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
        devkit = evaluate_sequences(load_folder(results, gt_root, "kitti", cls)[0], "kitti", cls, TRACKEVAL)
        te = headline(trackeval_kitti(gt_root, Path(tmp), cls, "val")["COMBINED_SEQ"])
    print(f"\n{args.benchmark} val (11 sequences), {args.tracker} tracker, overall: refimpl eval vs TrackEval's "
          "Kitti2DBox pipeline\n")
    print("| evaluator | HOTA | DetA | AssA | MOTA | IDF1 |\n|---|---:|---:|---:|---:|---:|")
    rows = {"refimpl eval": {k: ours.overall[k.lower()] for k in te},
            "refimpl eval --devkit trackeval": {k: devkit.overall[k.lower()] for k in te},
            "TrackEval Kitti2DBox (Evaluator)": te}
    for label, row in rows.items():
        print(f"| {label} | " + " | ".join(f"{100 * row[k]:.2f}" for k in ("HOTA", "DetA", "AssA", "MOTA", "IDF1"))
              + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
