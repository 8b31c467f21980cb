"""The files of the public benchmarks: where a benchmark's sequences are under a data root
(:class:`Benchmark`, the files part of a row of refimpl.io.datasets.CATALOGUE, which names every
dataset), the KITTI val / train splits, reading a benchmark sequence, and the bundled demo
sequence."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

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
MOT15_ACF = ("ETH-Sunnyday", "KITTI-13", "KITTI-17", "PETS09-S2L1", "TUD-Campus", "TUD-Stadtmitte", "Venice-2")
"""The MOT15 training sequences whose official (ACF) ``det/det.txt`` is on the data root: the files of
ADL-Rundle-6, ADL-Rundle-8, ETH-Bahnhof and ETH-Pedcross2 were not fetched (shared/data/PROVENANCE.md)."""
KITTI_TRAIN = tuple(f"{i:04d}" for i in range(21))
KITTI_VAL_SEQMAP = Path("KITTI") / "tracking" / "training" / "evaluate_tracking.seqmap.val"
"""The val split (AB3DMOT's): the sequences it lists are held out; the other training sequences
are the split tuned on (``kitti-*-train``)."""


@dataclass(frozen=True)
class Benchmark:
    """Where a public benchmark's files are under the data root: the files part of a dataset row
    (refimpl.io.datasets.CATALOGUE names every dataset; this module reads the files)."""

    format: str
    """MOT: MOT15/train/<sequence>/{det/<detections>, gt/gt.txt, seqinfo.ini}; KITTI:
    KITTI/tracking/training/{det_02_pointrcnn/<detections>/<sequence>.txt, label_02/<sequence>.txt}."""
    object_class: str
    detections: str
    """MOT: the detection file's name in det/; KITTI: the class folder in det_02_pointrcnn/."""
    sequences: tuple[str, ...]
    split: str = "all"
    """KITTI: all the listed sequences, or those in the val seqmap (val) or not in it (train)."""


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


def _mot15(root: Path, b: Benchmark) -> list[BenchmarkSequence]:
    out = []
    for name in b.sequences:
        seq = root / "MOT15" / "train" / name
        out.append(BenchmarkSequence(
            name=name, dets_path=seq / "det" / b.detections, gt_path=seq / "gt" / "gt.txt",
            format=MOT, object_class=b.object_class, seqinfo_path=seq / "seqinfo.ini"))
    return out


def _kitti(root: Path, b: Benchmark) -> list[BenchmarkSequence]:
    base = root / "KITTI" / "tracking" / "training"
    names = b.sequences
    if b.split != "all":
        val = set(kitti_val_sequences(root))
        names = tuple(n for n in names if (n in val) == (b.split == "val"))
    return [BenchmarkSequence(
        name=name, dets_path=base / "det_02_pointrcnn" / b.detections / f"{name}.txt",
        gt_path=base / "label_02" / f"{name}.txt", format=KITTI, object_class=b.object_class, seqinfo_path=None)
        for name in names]


def benchmark_files(name: str, b: Benchmark, data_root: str | os.PathLike) -> list[BenchmarkSequence]:
    """The sequences of benchmark ``b`` (called ``name`` in messages) under data_root (layout of
    /work/shared/data: ``Benchmark.format``); every file must exist.  By name:
    refimpl.io.datasets.benchmark_sequences."""
    root = Path(data_root)
    if not root.is_dir():
        raise InputFormatError(f"data root for benchmark {name!r} not found", root)
    seqs = _mot15(root, b) if b.format == MOT else _kitti(root, b)
    for s in seqs:
        for p in (s.dets_path, s.gt_path, s.seqinfo_path):
            if p is not None and not p.is_file():
                raise InputFormatError(
                    f"missing file of benchmark {name!r} (sequence {s.name}); is {root} the benchmark "
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


def bundled_data_dirs() -> tuple[Path, Path]:
    """Where the bundled ``data/`` is: a checkout's, then an installed package's ``refimpl/data``
    (pyproject: package-dir refimpl.data)."""
    here = Path(__file__).resolve()
    return here.parents[2] / "data", here.parents[1] / "data"


def demo_sequence_paths() -> BenchmarkSequence:
    """The bundled TUD-Campus demo (MOT15 gt + SORT Faster R-CNN dets), from a checkout or an install."""
    for base in bundled_data_dirs():
        found = _demo_in(base / "demo")
        if found is not None:
            return found
    raise InputFormatError("bundled demo sequence not found (expected data/demo/TUD-Campus in "
                           "the checkout or the refimpl.data package)", bundled_data_dirs()[0] / "demo")


def shipped_examples() -> dict[str, Path]:
    """The frame problems the package ships (``data/examples/NAME.lp``: the paper's fully listed
    frames), by NAME, from a checkout or an install; ``refimpl solve --example NAME`` reads them."""
    for base in bundled_data_dirs():
        found = sorted((base / "examples").glob("*.lp"))
        if found:
            return {p.stem: p for p in found}
    return {}
    # an installed package holds data/ as refimpl/data/ (pyproject: package-dir refimpl.data)
    found = _demo_in(Path(__file__).resolve().parents[1] / "data" / "demo")
    if found is None:
        raise InputFormatError("bundled demo sequence not found (expected data/demo/TUD-Campus in "
                               "the checkout or the refimpl.data package)", checkout)
    return found
