"""Where the abduction tracker's step goes, beside refimpl's own SORT baseline (docs/benchmarks.md,
issue 38, "What the peers' fps bar would take"):

    python tests/tools/step_split.py [--data ../shared/data] [--sets kitti-car-val,mot15,mot17-sim,mot20-01-sim]

Per benchmark set, the CPU milliseconds per frame of the abduction tracker's whole step (the preset
a user gets, `run_sequence` as `refimpl benchmark` times it) and of the baseline's, the two run
sequence by sequence in one loop with the heap frozen after a warm-up; and of the abduction's step
the solver's own share (`TrackingResult.solve_ms`, the solver's clock around `solve`: the fast
path's argument or the full model) against the rest (the frame's problem ⟨VO_t, P_t, ML_t⟩: the
Kalman predictions of every track, halted ones included, the matching likelihood and the facts;
then the update of the tracks, the event log and the rows).  A measurement, not a test.
"""

from __future__ import annotations

import argparse
import gc

from refimpl.io import get_format
from refimpl.io.datasets import dataset_kind, load_dataset
from refimpl.tracking.pipeline import Setup, run_sequence, setup_for


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default="../shared/data")
    ap.add_argument("--sets", default="kitti-car-val,mot15,mot17-sim,mot20-01-sim")
    args = ap.parse_args()
    print("| set | frames | abduction ms/frame | of it: solve | of it: the rest | baseline ms/frame | abduction / baseline |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for name in args.sets.split(","):
        data = load_dataset(name, args.data)
        fmt, cls = dataset_kind(name, args.data)
        abduction = setup_for(get_format(fmt).preset_format, cls, "cpsat", {}, {}, "auto", None, None)
        baseline = Setup("baseline")
        run_sequence(data[0][1], abduction), run_sequence(data[0][1], baseline)  # warm-up: imports, caches
        gc.collect()
        gc.freeze()  # as `refimpl track` runs (docs/benchmarks.md, "The slowest frames")
        times_a: list[float] = []
        times_b: list[float] = []
        solve_ms = 0.0
        for _, seq, _ in data:
            solve_ms += run_sequence(seq, abduction, frame_times=times_a).solve_ms
            run_sequence(seq, baseline, frame_times=times_b)
        gc.unfreeze()
        n = len(times_a)
        a, b, s = 1000 * sum(times_a) / n, 1000 * sum(times_b) / n, solve_ms / n
        print(f"| {name} | {n} | {a:.3f} | {s:.3f} | {a - s:.3f} | {b:.3f} | {a / b:.2f} |", flush=True)


if __name__ == "__main__":
    main()
