"""The learned gate (docs/model.md 3.33) through `refimpl diff`'s own comparison: track
box-noise-shifted tuning sequences with cpsat and their preset (learned_gate 45), re-solve every
frame with clingo, and count the frames whose problem carried a learned iou_thresh (in those
frames a preset's wander_noise acts too: the predictions the problems carry are the smoothed
filter's, docs/tracking.md 'A detector whose boxes wander').

    python tests/tools/diff_learned_gate.py [--data ../shared/data] [--benchmark mot15]
        [--sequences TUD-Campus,TUD-Stadtmitte,KITTI-17] [--shift box-noise]

`refimpl diff` tracks without a preset (its --const gives constants, not tracker options); this
runs refimpl.runs.diff.diff_sequence with the preset's setup (``setup=``) instead.  Prints, per sequence, the
frames, how many carried a gate below the constant, and the disagreements and divergences the diff
reports (both 0: clingo and CP-SAT give the same answer on every frame).
"""

from __future__ import annotations

import argparse

from refimpl.core.constants import resolve_constants
from refimpl.io import get_format
from refimpl.io.datasets import dataset_kind, load_dataset
from refimpl.io.shifts import shifted_dataset
from refimpl.runs.diff import diff_sequence
from refimpl.tracking.pipeline import run_sequence, setup_for


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default="../shared/data")
    ap.add_argument("--benchmark", default="mot15")
    ap.add_argument("--sequences", default="TUD-Campus,TUD-Stadtmitte,KITTI-17")
    ap.add_argument("--shift", default="box-noise")
    args = ap.parse_args()
    fmt, cls = dataset_kind(args.benchmark, args.data)
    base = setup_for(get_format(fmt).preset_format, cls, "cpsat")
    constant = dict(base.constants).get("iou_thresh", 30000)
    wanted = args.sequences.split(",")
    print(f"{args.benchmark} ({base.preset}, learned_gate {base.options.learned_gate}), --shift {args.shift}")
    for name, seq, _ in shifted_dataset(load_dataset(args.benchmark, args.data), args.shift):
        if name not in wanted:
            continue
        report = diff_sequence(seq, backends=("cpsat", "clingo"), setup=base)
        gated = []  # the same deterministic run again, its problems' gates counted
        run_sequence(seq, base, observer=lambda problem, _: gated.append(resolve_constants(problem)["iou_thresh"]))
        gated = [g for g in gated if g < constant]
        print(f"{name}: {report.frames} frames, {len(gated)} with a learned gate "
              f"({min(gated, default=constant)}..{max(gated, default=constant)}), "
              f"disagreements {report.disagreements}, divergences {len(report.divergences)}, "
              f"not proven {report.not_proven}", flush=True)


if __name__ == "__main__":
    main()
