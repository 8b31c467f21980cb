"""The dataset catalogue: named benchmarks (MOT15, KITTI tracking and its val / train splits)
under a data root, reading a catalogued sequence, and the bundled demo sequence."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

from .detections import DetectionSequence
from .errors import InputFormatError
from .formats import KITTI, MOT, get_format
from .ground_truth import GroundTruth
from .lines import _read_lines


@dataclass(frozen=True)
class BenchmarkSequence:
    """Where one benchmark sequence's detections and ground truth live, and how to read them."""

    name: str
    dets_path: Path
    gt_path: Path
    format: str
    object_class: str
    seqinfo_path: Path | None = None


MOT15_TRAIN = (
    "ADL-Rundle-6", "ADL-Rundle-8", "ETH-Bahnhof", "ETH-Pedcross2", "ETH-Sunnyday", "KITTI-13",
    "KITTI-17", "PETS09-S2L1", "TUD-Campus", "TUD-Stadtmitte", "Venice-2",
)
MOT15_SORT6 = ("TUD-Campus", "ETH-Sunnyday", "ETH-Pedcross2", "ADL-Rundle-8", "Venice-2", "KITTI-17")
KITTI_TRAIN = tuple(f"{i:04d}" for i in range(21))
KITTI_VAL_SEQMAP = Path("KITTI") / "tracking" / "training" / "evaluate_tracking.seqmap.val"
"""The val split (AB3DMOT's): the sequences it lists are held out; the other training sequences
are the split tuned on (``kitti-*-train``)."""
BENCHMARKS = ("mot15", "mot15-sort6", "kitti-car", "kitti-ped",
              "kitti-car-val", "kitti-ped-val", "kitti-car-train", "kitti-ped-train")


def _mot15(root: Path, names: Sequence[str]) -> list[BenchmarkSequence]:
    out = []
    for name in names:
        seq = root / "MOT15" / "train" / name
        out.append(BenchmarkSequence(
            name=name, dets_path=seq / "det" / "det_sort_frcnn.txt", gt_path=seq / "gt" / "gt.txt",
            format=MOT, object_class="pedestrian", seqinfo_path=seq / "seqinfo.ini"))
    return out


def kitti_val_sequences(root: str | os.PathLike) -> tuple[str, ...]:
    """The sequence names listed in the KITTI val seqmap (first field of each non-empty line)."""
    path = Path(root) / KITTI_VAL_SEQMAP
    if not path.is_file():
        raise InputFormatError("KITTI val seqmap not found (needed for the kitti-*-val/-train splits)", path)
    names = []
    for lineno, line in _read_lines(path):
        name = line.split()[0]
        if name not in KITTI_TRAIN:
            raise InputFormatError(f"sequence {name!r} is not a KITTI training sequence (0000-0020)", path, lineno)
        if name in names:
            raise InputFormatError(f"sequence {name!r} listed twice", path, lineno)
        names.append(name)
    if not names:
        raise InputFormatError("the KITTI val seqmap lists no sequence", path)
    return tuple(names)


def _kitti(root: Path, object_class: str, split: str = "all") -> list[BenchmarkSequence]:
    base = root / "KITTI" / "tracking" / "training"
    det_dir = base / "det_02_pointrcnn" / {"car": "Car", "pedestrian": "Pedestrian"}[object_class]
    names = KITTI_TRAIN
    if split != "all":
        val = set(kitti_val_sequences(root))
        names = tuple(n for n in KITTI_TRAIN if (n in val) == (split == "val"))
    return [BenchmarkSequence(
        name=name, dets_path=det_dir / f"{name}.txt", gt_path=base / "label_02" / f"{name}.txt",
        format=KITTI, object_class=object_class, seqinfo_path=None) for name in names]


def tuning_split(name: str) -> str | None:
    """The benchmark to tune on instead of a KITTI benchmark holding val sequences
    (``kitti-car`` / ``kitti-car-val`` -> ``kitti-car-train``); None for any other benchmark."""
    parts = name.strip().lower().split("-")
    if name not in BENCHMARKS or parts[0] != "kitti":
        return None
    return f"kitti-{parts[1]}-train"


def benchmark_sequences(name: str, data_root: str | os.PathLike) -> list[BenchmarkSequence]:
    """The sequences of a named benchmark under data_root (layout of /work/shared/data).

    ``mot15`` (11 MOT15 train sequences, SORT Faster R-CNN dets), ``mot15-sort6`` (the six
    sequences of the SORT paper's comparison), ``kitti-car`` / ``kitti-ped`` (KITTI tracking
    train 0000-0020, PointRCNN dets, label_02 ground truth), ``kitti-car-val`` / ``kitti-ped-val``
    (the sequences listed in ``KITTI/tracking/training/evaluate_tracking.seqmap.val``: 11) and
    ``kitti-car-train`` / ``kitti-ped-train`` (the other training sequences: 10), the split that
    anything tuned is tuned on.  Every file must exist.
    """
    root = Path(data_root)
    key = name.strip().lower()
    if key == "mot15":
        seqs = _mot15(root, MOT15_TRAIN)
    elif key == "mot15-sort6":
        seqs = _mot15(root, MOT15_SORT6)
    elif key.startswith("kitti-") and key in BENCHMARKS:
        _, cls, *split = key.split("-")
        if not root.is_dir():
            raise InputFormatError(f"data root for benchmark {key!r} not found", root)
        seqs = _kitti(root, {"car": "car", "ped": "pedestrian"}[cls], split[0] if split else "all")
    else:
        raise ValueError(f"unknown benchmark {name!r} (known: {', '.join(BENCHMARKS)})")
    if not root.is_dir():
        raise InputFormatError(f"data root for benchmark {key!r} not found", root)
    for s in seqs:
        for p in (s.dets_path, s.gt_path, s.seqinfo_path):
            if p is not None and not p.is_file():
                raise InputFormatError(
                    f"missing file of benchmark {key!r} (sequence {s.name}); is {root} the benchmark "
                    f"data root (holding MOT15/ and KITTI/)?", p)
    return seqs


def load_detections(seq: BenchmarkSequence) -> DetectionSequence:
    """Read a benchmark sequence's detections (a KITTI sequence's frame count from its label file)."""
    fmt = get_format(seq.format)
    n = fmt.frames_from_gt(Path(seq.gt_path)) if fmt.frames_from_gt is not None else None
    return fmt.read_detections(seq.dets_path, object_class=seq.object_class, seqinfo=seq.seqinfo_path, num_frames=n)


def load_ground_truth(seq: BenchmarkSequence) -> GroundTruth:
    """Read a benchmark sequence's ground truth."""
    return get_format(seq.format).read_ground_truth(seq.gt_path, object_class=seq.object_class,
                                                     seqinfo=seq.seqinfo_path)


def _demo_in(base: Path) -> BenchmarkSequence | None:
    seq = base / "TUD-Campus"
    paths = (seq / "det" / "det.txt", seq / "gt" / "gt.txt", seq / "seqinfo.ini")
    if all(p.is_file() for p in paths):
        return BenchmarkSequence(name="TUD-Campus", dets_path=paths[0], gt_path=paths[1],
                                 format=MOT, object_class="pedestrian", seqinfo_path=paths[2])
    return None


def demo_sequence_paths() -> BenchmarkSequence:
    """The bundled TUD-Campus demo (MOT15 gt + SORT Faster R-CNN dets), from a checkout or an install."""
    checkout = Path(__file__).resolve().parents[2] / "data" / "demo"
    found = _demo_in(checkout)
    if found is not None:
        return found
    # an installed package holds data/ as refimpl/data/ (pyproject: package-dir refimpl.data)
    found = _demo_in(Path(__file__).resolve().parents[1] / "data" / "demo")
    if found is None:
        raise InputFormatError("bundled demo sequence not found (expected data/demo/TUD-Campus in "
                               "the checkout or the refimpl.data package)", checkout)
    return found
