"""The user's path on every shared real sequence: single-input ``refimpl track`` with its defaults
must run on all 53 (MOT15 11 with SORT's detections, KITTI Car 21, KITTI Pedestrian 21) and write
exactly the bytes of ``track --pool-scores no --out-dir`` over the group's files, and the library's
``refimpl.Tracker`` with its defaults and ``history=True`` must give the same rows (``result().rows``;
byte for byte for KITTI, to the files' 0.01 px for MOTChallenge, whose x, y, w, h the API takes as
x1..y2), and every frame's ``update`` must return the same bytes with its defaults (no history,
bounded memory) as with ``history=True``.  A run over the group's files (``track --out-dir``, whose
score rule calibrates each file on the others too, docs/model.md 3.19) must write exactly what
``benchmark --results-dir`` writes, and the library given the other files (``calibrate_with=``)
the same rows.

    python tests/tools/check_user_path.py [--data ../shared/data] [--work DIR]

Every command runs as a user runs it (``python -m refimpl ...`` in a subprocess, defaults only);
prints one line per sequence and a summary; exit 1 on any difference or failure.
tests/test_user_path.py runs the same check on the eight sequences that once crashed.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

if not __package__:  # run as a script: this checkout's refimpl first on the import path
    import _paths  # noqa: F401

GROUPS = {
    "mot15": (["--format", "mot"], "MOT15/train/*/det/det_sort_frcnn.txt", "mot", "pedestrian"),
    "kitti-car": (["--format", "kitti", "--class", "Car"], "KITTI/tracking/training/det_02_pointrcnn/Car/*.txt",
                  "kitti", "car"),
    "kitti-ped": (["--format", "kitti", "--class", "Pedestrian"],
                  "KITTI/tracking/training/det_02_pointrcnn/Pedestrian/*.txt", "kitti", "pedestrian"),
}


def refimpl(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "refimpl", *args], capture_output=True, text=True)


def sequence_name(path: Path) -> str:
    return path.parent.parent.name if path.parent.name == "det" else path.stem


def api_rows(path: Path, fmt: str, cls: str, others: list[Path] = ()) -> tuple[bytes, bool]:
    """The library with its defaults and history=True (and the run's other files as
    ``calibrate_with``), fed the file's boxes and raw scores frame by frame: its rows as a results
    file, and whether every update returned the bytes a tracker with the defaults only (no history)
    returned."""
    import numpy as np

    import refimpl
    from refimpl import io
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        seq = io.get_format(fmt).read_detections(path, object_class=cls)
    tracker = refimpl.Tracker(format=fmt, object_type=cls, img_size=seq.image_size, fps=seq.fps, history=True,
                              calibrate_with=others)
    user = refimpl.Tracker(format=fmt, object_type=cls, img_size=seq.image_size, fps=seq.fps, calibrate_with=others)
    online = True
    for fr in seq.frames:
        b = fr.boxes
        dets = np.column_stack([b[:, 0], b[:, 1], b[:, 0] + b[:, 2], b[:, 1] + b[:, 3], fr.scores])
        online &= tracker.update(dets).tobytes() == user.update(dets).tobytes()
    return io.results_formatter(io.MOT, seq.first_frame, cls)(tracker.result().rows).encode(), online


def close(a: bytes, b: bytes) -> bool:
    """The same (frame, id) rows with boxes within the files' 0.01 px: the API takes x1, y1, x2, y2,
    so a MOTChallenge file's x, y, w, h come back as (x + w) - x, a last-bit float difference that
    can round the written two decimals the other way (KITTI files hold x1..y2: byte-identical)."""
    def rows(text: bytes):
        return {tuple(int(float(v)) for v in line.split(",")[:2]): [float(v) for v in line.split(",")[2:6]]
                for line in text.decode().splitlines()}
    ra, rb = rows(a), rows(b)
    return ra.keys() == rb.keys() and all(abs(x - y) <= 0.01 + 1e-9 for k in ra for x, y in zip(ra[k], rb[k]))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default="../shared/data")
    ap.add_argument("--work", default=None, help="keep the files here (default: a temporary folder)")
    args = ap.parse_args()
    data = Path(args.data)
    work = Path(args.work or tempfile.mkdtemp(prefix="user-path-"))
    work.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    done = refimpl("benchmark", *GROUPS, "--data", str(data), "--quiet", "--results-dir", str(work / "benchmark"))
    if done.returncode:
        print(done.stderr, file=sys.stderr)
        return 1
    bad = total = 0
    for group, (flags, pattern, fmt, cls) in GROUPS.items():
        files = sorted(data.glob(pattern))
        many = refimpl("track", "--dets", *map(str, files), *flags, "--out-dir", str(work / group), "--quiet")
        apart = refimpl("track", "--dets", *map(str, files), *flags, "--pool-scores", "no",
                        "--out-dir", str(work / f"{group}-apart"), "--quiet")
        if many.returncode or apart.returncode:
            print(f"{group}: track --out-dir failed: {many.stderr.strip()} {apart.stderr.strip()}")
            bad += len(files)
            continue
        for path in files:
            total += 1
            name = sequence_name(path)
            single = work / f"{group}-{name}.txt"
            one = refimpl("track", "--dets", str(path), *flags, "--out", str(single), "--quiet")
            if one.returncode:
                bad += 1
                print(f"{group}/{name}: FAILED (exit {one.returncode}): {one.stderr.strip().splitlines()[-1:]}")
                continue
            mine = single.read_bytes()
            api, online = api_rows(path, fmt, cls)
            run = (work / group / f"{name}.txt").read_bytes()
            api_run, online_run = api_rows(path, fmt, cls, [f for f in files if f != path])
            same = {"out-dir --pool-scores no": mine == (work / f"{group}-apart" / f"{name}.txt").read_bytes(),
                    "api": mine == api or close(mine, api), "api-update": online,
                    "benchmark": run == (work / "benchmark" / group / f"{name}.txt").read_bytes(),
                    "api calibrate_with": run == api_run or close(run, api_run),
                    "api-update calibrate_with": online_run}
            verdict = "equal" if all(same.values()) else "DIFFERS: " + ", ".join(k for k, v in same.items() if not v)
            bad += not all(same.values())
            alone, in_run = mine.count(b"\n"), run.count(b"\n")
            warned = [line for line in one.stderr.splitlines() if "warning:" in line]  # what the user is told
            print(f"{group}/{name}: {alone} rows alone, {in_run} in the run; track --out == "
                  f"--out-dir --pool-scores no == API, --out-dir == benchmark == API calibrate_with, update() "
                  f"with == without history: {verdict}" + "".join(f"\n    {line}" for line in warned))
    print(f"{total} sequences, {total - bad} equal, {bad} failing ({time.perf_counter() - started:.0f} s; "
          f"files in {work})")
    return 1 if bad or total != 53 else 0


if __name__ == "__main__":
    sys.exit(main())
