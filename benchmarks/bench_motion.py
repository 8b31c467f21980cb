"""Motion while hidden (issue 12, item 4): the tracker's two motion options off / on, on real benchmarks.

    python benchmarks/bench_motion.py [--datasets mot15,kitti-car] [--trackers cpsat,cpsat+hold,cpsat+oru,cpsat+hold+oru]

Prints one markdown table: MOTA, IDF1, IDs, Frag per dataset and variant; for KITTI also the 11
sequences of evaluate_tracking.seqmap.val on their own (nothing here is tuned, so train/val only
label the split).  Variants are parsed by refimpl.experiments.occlusion_bench.parse_variant ('+hold': a halted
track's prediction keeps constant velocity, bounded, size frozen; '+oru': observation-centric
re-update when a track resumes).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from refimpl.evaluation.evaluate import combine, evaluate_many
from refimpl.experiments.occlusion_bench import parse_variant
from refimpl.io.datasets import load_dataset
from refimpl.solvers import BASELINE
from refimpl.tracking.options import TrackerOptions
from refimpl.tracking.pipeline import Setup, run_sequence

VAL_SEQMAP = Path("KITTI/tracking/training/evaluate_tracking.seqmap.val")


def _row(label: str, variant: str, r: dict) -> str:
    return (f"| {label} | {variant} | {100 * r['mota']:.1f} | {100 * r['idf1']:.1f} | {r['idsw']} | {r['frag']} | "
            f"{r['idsw'] + r['frag']} |")


def _setup(backend: str, options: dict) -> Setup:
    """The Setup of a parsed variant: no preset, its model constants ('+persist') and tracker options."""
    if backend == BASELINE:
        return Setup(BASELINE)
    options = dict(options)
    constants = options.pop("constants", {})
    return Setup(backend, tuple(constants.items()), TrackerOptions.from_mapping(options))


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--data", default="../shared/data")
    ap.add_argument("--datasets", default="mot15,kitti-car")
    ap.add_argument("--trackers", default="cpsat,cpsat+hold,cpsat+oru,cpsat+hold+oru")
    args = ap.parse_args()
    variants = [(v, *parse_variant(v)) for v in args.trackers.split(",")]
    val = {line.split()[0] for line in (Path(args.data) / VAL_SEQMAP).read_text().splitlines() if line.strip()}
    print("| dataset | variant | MOTA | IDF1 | IDs | Frag | IDs+Frag |")
    print("|---|---|---:|---:|---:|---:|---:|")
    for name in args.datasets.split(","):
        dataset = load_dataset(name, args.data)
        for variant, backend, options in variants:
            t0 = time.perf_counter()
            setup = _setup(backend, options)
            triples = [(s, gt, run_sequence(dets, setup).rows) for s, dets, gt in dataset]
            per_seq, overall = evaluate_many(triples)
            print(_row(f"{name} ({len(per_seq)})", variant, overall), flush=True)
            if name.startswith("kitti"):
                sub = [r for s, r in per_seq.items() if s in val]
                print(_row(f"{name} val ({len(sub)})", variant, combine(sub)), flush=True)
            print(f"<!-- {name} {variant}: {time.perf_counter() - t0:.0f} s -->", flush=True)


if __name__ == "__main__":
    main()
