"""The argument parser of the `refimpl` command: every subcommand, its options and help, and the
command table (``COMMANDS``: the function that runs each command)."""

from __future__ import annotations

import argparse

from .. import __version__
from ..evaluation import DEVKITS
from ..runs.scaleout import LOCAL_MIN_FRAMES_PER_WORKER
from ..io import DEFAULT_SCORE_RULE, FORMAT_NAMES, MOT, RESULT_FORMATS, SCORE_RULES, shipped_examples
from ..io.datasets import HELD_OUT_DATASETS, REAL_DETECTORS
from ..io.shifts import SHIFTS
from ..tracking.options import TRACKER_OPTIONS, TrackerOption, TrackerOptions
from ..tracking.peer_table import PEERS
from ..tracking.pipeline import DEFAULT_FRAME_BUDGET_MS
from .strict_args import _Append, _Once, _Parser, _Several  # noqa: F401  (the tests read the actions here)
from .common import (BACKENDS, BASELINE, BENCHMARKS, CLASSES, DEFAULT_BACKEND, ORACLE_PAIR, REFERENCE_BACKEND,
                     TRACKERS, _parse_const, _parse_fps, _parse_img_size, _time_limit)


def _class_name(text: str) -> str:
    key = text.lower()
    if key not in CLASSES:
        raise argparse.ArgumentTypeError(f"unknown class {text!r} (choose Car, Pedestrian or Cyclist)")
    return CLASSES[key]


def _add_markdown_out(p: argparse.ArgumentParser, doc: str, sections: bool = False) -> None:
    """--out of a benchmark command that rewrites its generated part of a document (write_section)."""
    part = "sections are" if sections else "section is"
    p.add_argument("--out", default=doc,
                   help=f"markdown file whose generated {part} replaced (default {doc}; - for none)")


def _add_preset(p: argparse.ArgumentParser) -> None:
    """--preset and --no-preset (refimpl.tracking.pipeline.setup_for: which preset the abduction tracker runs)."""
    p.add_argument("--preset", default=None, metavar="NAME",
                   help="the preset to run with: auto (that of the format and class, else the robust default), none, "
                        "or a name of model/presets.json (kitti/car, default, ...) (default: auto)")
    p.add_argument("--no-preset", action="store_true",
                   help="abduction with model/constants.lp's defaults and the tracker's default options instead of "
                        "the calibrated preset (model/presets.json); the same as --preset none")


def _add_tracker_options(p: argparse.ArgumentParser) -> None:
    """The tracker options a preset carries (refimpl.tracking.options.TRACKER_OPTIONS), overridable here."""
    for option in TRACKER_OPTIONS:
        p.add_argument(option.flag, dest=option.name, type=_option_value(option), default=None,
                       choices=option.choices, metavar=None if option.choices else "X",
                       help=f"abduction: {option.help} (default: the preset's; "
                            f"{TrackerOption.text(getattr(TrackerOptions(), option.name))} without one or with --no-preset)")


def _option_value(option: "TrackerOption"):
    """argparse's type: the option's own parser, its error as argparse's one-line message."""
    def parse(text: str):
        if option.choices:
            return text  # argparse checks the choices; TrackerOptions parses them
        try:
            return option.parse(text)
        except ValueError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None
    return parse


def _add_scaleout(p: argparse.ArgumentParser) -> None:
    p.add_argument("--workers", type=int, default=None, metavar="N",
                   help="run the sequences as tasks on a local Dask cluster of N processes, when there are at "
                        f"least {LOCAL_MIN_FRAMES_PER_WORKER} x N frames (fewer: serially, the same bytes; "
                        "docs/scale-out.md)")
    p.add_argument("--serial-below", type=int, default=None, metavar="FRAMES",
                   help="with --workers: start the local cluster only for at least this many frames "
                        f"(default {LOCAL_MIN_FRAMES_PER_WORKER} x N; 0: always)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="run the tasks on an existing Dask cluster, e.g. tcp://10.0.0.5:8786")
    p.add_argument("--connect-timeout", type=_time_limit, default=None, metavar="SECONDS",
                   help="with --scheduler: give up when the scheduler does not answer for this long, at the "
                        "start or during the run (default 10)")
    p.add_argument("--worker-timeout", type=_time_limit, default=None, metavar="SECONDS",
                   help="with --workers or --scheduler: give up when the cluster has had no worker for this "
                        "long, none joined or every one lost (default 60)")


def _parse_grid(text: str) -> tuple[str, tuple[int, ...]]:
    name, sep, values = text.partition("=")
    try:
        if not sep or not name.strip():
            raise ValueError
        parsed = tuple(int(v) for v in values.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected NAME=INTEGER,INTEGER,..., got {text!r}") from None
    if len(set(parsed)) != len(parsed):
        raise argparse.ArgumentTypeError(f"a value is given twice in {text!r}")
    return name.strip(), parsed


def _add_solve(sub: "argparse._SubParsersAction") -> None:
    s = sub.add_parser("solve", help="abduce the best hypothesis for one frame problem (fact file)")
    s.add_argument("file", nargs="?", help="fact file in the paper's syntax (det/3, box2d/5, trk/2, trk_state/2, "
                                           "iou/3, ...)")
    s.add_argument("--example", choices=sorted(shipped_examples()), metavar="NAME",
                   help="instead of FILE, a frame the package ships (data/examples/NAME.lp, the paper's fully listed "
                        f"frames; found in the checkout or the installed package): {', '.join(sorted(shipped_examples()))}")
    s.add_argument("--backend", choices=BACKENDS, default=DEFAULT_BACKEND)
    s.add_argument("--json", action="store_true", help="print one JSON object")
    s.add_argument("--time-limit", type=_time_limit, default=None, metavar="SECONDS",
                   help="stop after this many seconds, reading the file included, with the best answer found "
                        "(flagged NOT proven optimal) or one line (default: no limit)")
    s.add_argument("--const", type=_parse_const, action="append", metavar="NAME=VALUE",
                   help="override a model constant (repeatable)")
    s.add_argument("--check", action="store_true",
                   help="verify the answer with the independent checker; exit 1 on any violation")


def _add_track(sub: "argparse._SubParsersAction") -> None:
    t = sub.add_parser("track", help="track a detection file and write MOTChallenge results")
    t.add_argument("--dets", required=True, nargs="+", metavar="PATH",
                   help="detections: MOTChallenge det.txt or KITTI PointRCNN file (several with --out-dir); - reads "
                        "them from standard input frame by frame as a detector writes them (docs/robustness.md)")
    t.add_argument("--seqinfo", metavar="SEQINFO.ini",
                   help="with --dets - (MOTChallenge): the sequence's seqinfo.ini (name, image size, frame rate, "
                        "length), which a file finds beside it")
    t.add_argument("--format", choices=FORMAT_NAMES, default=MOT)
    t.add_argument("--class", dest="cls", type=_class_name, help="object class for KITTI: Car|Pedestrian|Cyclist")
    t.add_argument("--backend", choices=TRACKERS, default=DEFAULT_BACKEND,
                   help=f"the paper's method by abduction ({', '.join(BACKENDS)}) or {BASELINE} (SORT)")
    t.add_argument("--out", help="results file of one --dets (MOTChallenge format unless --out-format kitti; "
                                 "- for standard output)")
    t.add_argument("--scores", choices=SCORE_RULES, default=DEFAULT_SCORE_RULE,
                   help="how detection scores become the model's confidences 0..100, the same rules for every "
                        "format: auto (the default, on every format) is evidence: calibrated, without labels, on how "
                        "persistent the detections of each score are in the sequence so far (any detector, any "
                        "scale: only the scores' order matters; docs/model.md 3.19); rank (their place among the "
                        "scores seen so far, mapped onto 20..100); or read as numbers: probability (0..1), sigmoid "
                        "(logits, such as KITTI's PointRCNN scores), raw (0..100)")
    t.add_argument("--pool-scores", choices=("yes", "no"), default="yes",
                   help="with several --dets and an online rule (evidence, rank): yes (the default) calibrates "
                        "each file on its own frames so far and on the other files whole, one detector's scores "
                        "meaning the same in every file of a run (docs/model.md 3.19); no: each file alone (files "
                        "from different detectors)")
    t.add_argument("--out-dir", metavar="DIR", help="one results file per --dets, named after its MOTChallenge "
                   "sequence folder (.../TUD-Campus/det/det.txt -> TUD-Campus.txt) or its file stem (0011.txt)")
    t.add_argument("--out-format", choices=RESULT_FORMATS, default=MOT,
                   help="results as MOTChallenge lines (default; KITTI frames stay 0-based) or in the KITTI "
                        "tracking format TrackEval's KITTI loader reads (needs --format kitti)")
    t.add_argument("--const", type=_parse_const, action="append", metavar="NAME=VALUE",
                   help="override a model constant (repeatable; as solve --const; abduction backends; on top "
                        "of the preset of --format/--class)")
    t.add_argument("--img-size", type=_parse_img_size, metavar="W,H",
                   help="image width and height in pixels (the field-of-view border and the pixel constants, "
                        "docs/model.md 3.22; default: seqinfo.ini, 1242,375 for KITTI, unknown otherwise)")
    t.add_argument("--fps", type=_parse_fps, metavar="FPS",
                   help="frames per second of the video, 0.1 to 1000: the preset's durations become the "
                        "same seconds at this rate and a halt is bounded at 10 s (docs/model.md 3.22; default: "
                        "seqinfo.ini's frameRate, 10 for KITTI, unknown otherwise: durations in frames as written)")
    t.add_argument("--events", help="write the abduced event log in the paper's syntax")
    t.add_argument("--events-json", help="write the event log as JSON lines")
    t.add_argument("--time-limit", type=_time_limit, default=None, metavar="SECONDS",
                   help="per-frame solver limit; the best answer found in time is used and counted")
    t.add_argument("--frame-budget", default="auto", metavar="MS",
                   help="milliseconds a frame may take (wall-clock, building its problem and solving it): a "
                        "frame that reaches it gets the best answer found so far, flagged not proven optimal and "
                        "counted in the summary; the fast path's answer, exact and never interrupted, is kept "
                        f"however late. 'auto' (default): {DEFAULT_FRAME_BUDGET_MS:g} ms for the "
                        "real-time backend (cpsat), none for cpsat-full and clingo; 'none': no budget")
    t.add_argument("--check", action="store_true",
                   help="verify every frame's answer with the independent checker; exit 1 on any violation")
    t.add_argument("--scene", metavar="SCENE.json", help="write the scene (tracks, events, fluent timelines) "
                   "for query / explain / plot (an abduction backend)")
    _add_preset(t)
    _add_tracker_options(t)
    _add_scaleout(t)
    t.add_argument("--quiet", action="store_true", help="no progress bar")


def _add_eval(sub: "argparse._SubParsersAction") -> None:
    e = sub.add_parser("eval", help="HOTA, CLEAR MOT and IDF1 of a results file, or of a folder of them "
                                     "(one <SEQ>.txt per sequence), against ground truth")
    e.add_argument("results", help="results file, or folder of <SEQ>.txt results files (MOTChallenge lines; "
                                   "for --format kitti also the KITTI tracking format)")
    e.add_argument("--gt", required=True, help="ground truth: MOTChallenge gt.txt or KITTI label_02 file; for a "
                   "results folder the root: ROOT/<SEQ>/gt/gt.txt (mot), ROOT/label_02/<SEQ>.txt or ROOT/<SEQ>.txt (kitti)")
    e.add_argument("--format", choices=FORMAT_NAMES, default=MOT)
    e.add_argument("--class", dest="cls", type=_class_name, help="object class for KITTI: Car|Pedestrian|Cyclist")
    e.add_argument("--json", help="also write {\"devkit\", \"convention\", \"sequences\": {...}, \"overall\": {...}} "
                                  "(HOTA, DetA, AssA, MOTA, MOTP, IDF1 as fractions; IDs, Frag, FP, FN, MT, ML) to "
                                  "this file")
    e.add_argument("--devkit", choices=DEVKITS, default=DEVKITS[0],
                   help="refimpl (default): refimpl's simplified devkit (no KITTI truncation/occlusion/height filter; "
                        "docs/evaluation.md); trackeval: TrackEval's own Kitti2DBox / MotChallenge2DBox pipeline on "
                        "the same files, the numbers a TrackEval leaderboard gives")


def _add_benchmark(sub: "argparse._SubParsersAction") -> None:
    b = sub.add_parser("benchmark", help="track and evaluate every sequence of a benchmark")
    b.add_argument("names", nargs="+", choices=BENCHMARKS, metavar="NAME",
                   help=f"one or more of {', '.join(BENCHMARKS)}; *-sim use simulated detections (refimpl.io.simulate); "
                        f"{', '.join(HELD_OUT_DATASETS)} are held out (never tuned on)")
    b.add_argument("--data", default="../shared/data", help="benchmark data root (default ../shared/data)")
    b.add_argument("--backend", choices=TRACKERS, default=DEFAULT_BACKEND,
                   help=f"the paper's method by abduction ({', '.join(BACKENDS)}) or {BASELINE} (SORT)")
    b.add_argument("--json", help="also write the metrics as JSON")
    b.add_argument("--results-dir", metavar="DIR",
                   help="also write every scored sequence's results file, DIR/<dataset>/<sequence>.txt (the "
                        "lines refimpl track writes)")
    b.add_argument("--quiet", action="store_true", help="no progress bar")
    b.add_argument("--peers", metavar="LIST",
                   help="compare with peer trackers, 'all' (every one whose package is installed, the others "
                        f"named) or a comma-separated list out of {','.join(PEERS)} "
                        "(sort, bytetrack, ocsort: the 'trackers' package, extra 'peers'; boxmot-*: BoxMOT's "
                        "motion-only trackers, extra 'peers-boxmot'): baseline, abduction (--backend, "
                        f"{DEFAULT_BACKEND} if {BASELINE}) and every peer in one table per dataset")
    b.add_argument("--out", help="with --peers: write the tables into this markdown file (between marker comments)")
    b.add_argument("--shift", metavar="LIST",
                   help="re-run under detector and camera shifts of the datasets' own sequences, 'all' (every "
                        "one but " + ", ".join(n for n, s in SHIFTS.items() if not s.in_all) + ") or a "
                        "comma-separated list out of " + ", ".join(SHIFTS) + ", each name alone or several joined "
                        "by '+', applied one after the other (refimpl/io/shifts.py): "
                        "HOTA / IDF1 of the baseline, abduction and any --peers per shift, the worst case and the "
                        "largest drop")
    b.add_argument("--repeat", type=int, default=1, metavar="N",
                   help="with --peers: time every tracker on every sequence N times, interleaved, and report each "
                        "sequence's fastest run (speed columns only; default 1)")
    b.add_argument("--per-sequence", action="store_true",
                   help="with --peers: also a table per dataset of every sequence (HOTA / IDF1 / IDs per tracker)")
    b.add_argument("--const", type=_parse_const, action="append", metavar="NAME=VALUE",
                   help="override a model constant of the abduction tracker (repeatable; on top of the preset)")
    _add_preset(b)
    _add_tracker_options(b)
    _add_scaleout(b)


def _add_calibrate(sub: "argparse._SubParsersAction") -> None:
    cb = sub.add_parser("calibrate", help="grid-search the model's thresholds on a benchmark (its training split) "
                                          "and print the ranked table; the best point is the preset")
    cb.add_argument("--benchmark", required=True, nargs="+", choices=BENCHMARKS, metavar="NAME",
                    help="one or more benchmarks to tune on, each giving the preset of its format/class: "
                         "kitti-car-train, kitti-ped-train, mot15 (leave-one-sequence-out)")
    cb.add_argument("--grid", action="append", metavar="NAME=V1,V2,...",
                    help="replace (or add) one dimension of the search space (repeatable)")
    cb.add_argument("--backend", choices=BACKENDS, default=DEFAULT_BACKEND)
    cb.add_argument("--loso", action="store_true", help="also leave-one-sequence-out (default for MOT benchmarks)")
    cb.add_argument("--default", action="store_true",
                    help="choose the robust default preset instead: every stored preset (and none) on every named "
                         "benchmark, the best mean rank of HOTA (what a format/class without a preset runs with)")
    cb.add_argument("--top", type=int, default=None, help="print only the best N points")
    cb.add_argument("--write-presets", action="store_true", help="store the best point as the preset (model/presets.json)")
    cb.add_argument("--out", help="write the report into this markdown file (between marker comments)")
    cb.add_argument("--data", default="../shared/data", help="benchmark data root (default ../shared/data)")
    cb.add_argument("--quiet", action="store_true", help="no progress bar")
    _add_scaleout(cb)


def _add_table6(sub: "argparse._SubParsersAction") -> None:
    t6 = sub.add_parser("table6", help="the paper's Table 6 on our data: baseline vs abduction on every dataset")
    t6.add_argument("--data", default="../shared/data", help="benchmark data root (default ../shared/data)")
    t6.add_argument("--backend", choices=BACKENDS, default=DEFAULT_BACKEND)
    t6.add_argument("--datasets", help="comma-separated subset of mot15,kitti-car,kitti-ped,mot17-sim,mot20-01-sim")
    t6.add_argument("--out", help="also write the markdown table to this file")
    t6.add_argument("--quiet", action="store_true", help="no progress bar")
    _add_scaleout(t6)


def _add_diff(sub: "argparse._SubParsersAction") -> None:
    x = sub.add_parser("diff", help="track with one backend and re-solve every frame with the other; "
                                     "exit 1 on any cost disagreement")
    x.add_argument("--dets", nargs="+", metavar="PATH", help="detections of one or more sequences")
    x.add_argument("--format", choices=FORMAT_NAMES, default=MOT)
    x.add_argument("--class", dest="cls", type=_class_name, help="object class for KITTI")
    x.add_argument("--benchmark", choices=BENCHMARKS, help="diff every sequence of a benchmark instead")
    x.add_argument("--data", default="../shared/data", help="benchmark data root (with --benchmark)")
    x.add_argument("--backends", default=",".join(ORACLE_PAIR),
                   help=f"FIRST,SECOND[,THIRD] out of {','.join(BACKENDS)}: track with the first, re-solve every "
                        f"frame with the others (default {','.join(ORACLE_PAIR)})")
    x.add_argument("--time-limit", type=_time_limit, default=20.0, metavar="SECONDS",
                   help="per-frame limit of every backend (default 20); a frame not proven optimal in time "
                        "is reported as such")
    x.add_argument("--const", type=_parse_const, action="append", metavar="NAME=VALUE",
                   help="override a model constant (repeatable; on top of model/constants.lp, no preset: "
                        "give a preset's constants here to diff the rules it turns on)")
    x.add_argument("--asp-model", metavar="DIR",
                   help="the clingo backend runs your own encoding, every DIR/*.lp, instead of model/ "
                        "(docs/model.md, 'Your own encoding'); without refimpl's tie-break it is compared on "
                        "levels 10..1 and equal-cost different answers are counted as ties")
    x.add_argument("--quiet", action="store_true", help="no progress bar")
    _add_scaleout(x)


def _add_sweep(sub: "argparse._SubParsersAction") -> None:
    sw = sub.add_parser("sweep", help="track and score a benchmark for every combination of model constants "
                                      "(one task per setting and sequence); one table")
    sw.add_argument("--benchmark", required=True, choices=BENCHMARKS, metavar="NAME",
                    help=f"one of {', '.join(BENCHMARKS)}")
    sw.add_argument("--grid", required=True, action="append", type=_parse_grid, metavar="NAME=V1,V2,...",
                    help="a model constant and its integer values (repeatable; the settings are all combinations)")
    sw.add_argument("--split", choices=("all", "tune", "val"), default="all",
                    help="KITTI: tune = the 10 training sequences outside evaluate_tracking.seqmap.val, "
                         "val = the 11 in it (default all)")
    sw.add_argument("--backend", choices=BACKENDS, default=DEFAULT_BACKEND)
    sw.add_argument("--data", default="../shared/data", help="benchmark data root (default ../shared/data)")
    sw.add_argument("--json", help="also write every setting's overall scores as JSON")
    sw.add_argument("--quiet", action="store_true", help="no progress bar")
    _add_scaleout(sw)


def _add_demo(sub: "argparse._SubParsersAction") -> None:
    d = sub.add_parser("demo", help="track the bundled sample sequence and print its metrics")
    d.add_argument("--backends", default=f"{BASELINE},{DEFAULT_BACKEND}",
                   help=f"comma-separated trackers to run out of {','.join(TRACKERS)} (default {BASELINE},{DEFAULT_BACKEND})")


def _add_bench_scale(sub: "argparse._SubParsersAction") -> None:
    sc = sub.add_parser("bench-scale", help="time the backends on synthetic frames (or, with --throughput, "
                                             "the tracking loop on MOT15 and KITTI Car); writes docs/benchmarks.md")
    sc.add_argument("--sizes", help="tracks per frame (default 5,10,20,50,100,200; with --dense 50,100,200,400)")
    sc.add_argument("--dense", action="store_true",
                    help="instead of the overlap frames: dense crowds, each frame one component "
                         "(refimpl.experiments.synthetic.dense_frame; --overlaps is not used)")
    sc.add_argument("--overlaps", default="0.2,0.5,0.8", help="overlap shares (default 0.2,0.5,0.8)")
    sc.add_argument("--seeds", type=int, default=10, help="frames per size and overlap (default 10)")
    sc.add_argument("--backends", default=",".join(BACKENDS),
                    help=f"solvers to time (default {','.join(BACKENDS)})")
    sc.add_argument("--time-limit", type=_time_limit, default=20.0, metavar="SECONDS",
                    help="per-frame time limit of every backend (default 20)")
    _add_markdown_out(sc, "docs/benchmarks.md")
    sc.add_argument("--plot", help="PNG plot of a scalability run (default scalability.png beside --out)")
    sc.add_argument("--json", help="also save the raw per-frame (per-sequence) results as JSON")
    sc.add_argument("--from-json", metavar="PATH", help="redraw tables and plot from saved JSON, solving nothing")
    sc.add_argument("--throughput", action="store_true",
                    help="instead: frames/s of the tracking loop per tracker on MOT15 and KITTI Car")
    sc.add_argument("--trackers", default=f"{BASELINE},{DEFAULT_BACKEND},{REFERENCE_BACKEND}",
                    help=f"trackers for --throughput out of {','.join(TRACKERS)} (default {BASELINE},{DEFAULT_BACKEND},{REFERENCE_BACKEND})")
    sc.add_argument("--data", default="../shared/data", help="benchmark data root for --throughput")
    sc.add_argument("--quiet", action="store_true", help="no progress bar")


def _add_bench_latency(sub: "argparse._SubParsersAction") -> None:
    la = sub.add_parser("bench-latency", help="CPU per frame (p50, p99, worst) with the defaults a user gets on "
                                              "KITTI Car val and MOT15, or (--crowds) against the objects per "
                                              "frame; writes docs/benchmarks.md")
    la.add_argument("--crowds", action="store_true",
                    help="instead: simulated crowds of --sizes objects per frame (refimpl.experiments.crowds), every "
                         "--trackers and --peers on each, and the exponent of cost ~ objects^k")
    la.add_argument("--datasets", default="kitti-car-val,mot15", help="datasets (default kitti-car-val,mot15)")
    la.add_argument("--backend", default=DEFAULT_BACKEND, help=f"abduction backend (default {DEFAULT_BACKEND})")
    la.add_argument("--sizes", default="10,50,100,200,400", help="--crowds: objects per frame (default "
                                                                 "10,50,100,200,400)")
    la.add_argument("--frames", type=int, default=15, help="--crowds: frames per size (default 15)")
    la.add_argument("--trackers", default=",".join(TRACKERS),
                    help=f"--crowds: refimpl's trackers (default {','.join(TRACKERS)})")
    la.add_argument("--peers", default="sort,bytetrack,ocsort",
                    help="--crowds: peer trackers, or none (default sort,bytetrack,ocsort)")
    la.add_argument("--time-limit", type=_time_limit, default=None, metavar="SECONDS",
                    help="--crowds: per-frame limit of the abduction backends (default none)")
    la.add_argument("--seed", type=int, default=0, help="--crowds: simulation seed (default 0)")
    la.add_argument("--data", default="../shared/data", help="benchmark data root (default ../shared/data)")
    _add_markdown_out(la, "docs/benchmarks.md")
    la.add_argument("--quiet", action="store_true", help="no progress bar")


def _add_bench_peers(sub: "argparse._SubParsersAction") -> None:
    bp = sub.add_parser("bench-peers", help="every generated section of docs/peers.md in one run: what was tuned on "
                                            "what, the peer tables and the shift tables, on the datasets the dataset "
                                            "registry names for them (refimpl/io/datasets.py)")
    bp.add_argument("--peers", metavar="LIST",
                    help=f"only these peers, a comma-separated list out of {','.join(PEERS)} (default: every one "
                         "whose package is installed; the others are named on stderr and in the sections)")
    bp.add_argument("--data", default="../shared/data", help="benchmark data root (default ../shared/data)")
    _add_markdown_out(bp, "docs/peers.md", sections=True)
    bp.add_argument("--json", help="also write the metrics as JSON")
    bp.add_argument("--quiet", action="store_true", help="no progress bar")


def _add_detectors(sub: "argparse._SubParsersAction") -> None:
    dt = sub.add_parser("detectors", help="which detector, and how much abduction helps it: real detectors side "
                                          "by side, or (--sweep) a simulated detector-quality grid")
    dt.add_argument("--data", default="../shared/data", help="benchmark data root (default ../shared/data)")
    dt.add_argument("--backend", default=DEFAULT_BACKEND, help=f"abduction backend (default {DEFAULT_BACKEND})")
    dt.add_argument("--benchmarks", default=",".join(REAL_DETECTORS),
                    help=f"real-detector benchmarks (default {','.join(REAL_DETECTORS)})")
    dt.add_argument("--sequences", help="comma-separated subset of sequences (one benchmark or sweep dataset)")
    dt.add_argument("--max-frames", type=int, help="only the first N frames of every sequence")
    dt.add_argument("--ungated", action="store_true",
                    help="also track every detector's boxes by abduction with every confidence set to 100")
    dt.add_argument("--sweep", action="store_true", help="instead: the simulated detector-quality sweep")
    dt.add_argument("--sweep-datasets", default="mot17,kitti-car", help="sweep ground truth (default mot17,kitti-car)")
    dt.add_argument("--p-max", default="0.5,0.7,0.9", help="sweep: detection probabilities (default 0.5,0.7,0.9)")
    dt.add_argument("--fp-per-frame", default="0.5,2,5", help="sweep: false positives per frame (default 0.5,2,5)")
    dt.add_argument("--noise", default="0.03,0.1", help="sweep: localisation noise (default 0.03,0.1)")
    dt.add_argument("--seed", type=int, default=0, help="sweep: simulated detector seed (default 0)")
    dt.add_argument("--out", default="-", help="markdown file whose generated section is replaced "
                    "(e.g. docs/detectors.md; default - for none)")
    dt.add_argument("--plot", help="sweep: PNG plot (default detectors-sweep.png beside --out)")
    dt.add_argument("--json", help="also write the raw numbers as JSON")
    dt.add_argument("--quiet", action="store_true", help="no progress bar")


def _add_occlusion_suite(sub: "argparse._SubParsersAction") -> None:
    oc = sub.add_parser("occlusion-suite", help="write the long-occlusion suite (docs/occlusion.md) as "
                                                "MOTChallenge sequences: DIR/<scenario>/{det,gt,seqinfo.ini}")
    oc.add_argument("--out", required=True, metavar="DIR", help="folder to write the scenarios into")
    oc.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    oc.add_argument("--force", action="store_true", help="overwrite scenario folders that exist")


def _add_bench_occlusion(sub: "argparse._SubParsersAction") -> None:
    bo = sub.add_parser("bench-occlusion", help="baseline vs abduction on the long-occlusion suite: identity kept, "
                                                "hide/unhide events on time (writes docs/occlusion.md)")
    bo.add_argument("--trackers", default=f"{BASELINE},{DEFAULT_BACKEND}",
                    help="comma-separated variants: baseline, a backend, backend+hold, backend+oru, "
                         f"backend+hold+oru (default {BASELINE},{DEFAULT_BACKEND})")
    bo.add_argument("--seed", type=int, default=0, help="suite seed (default 0)")
    _add_markdown_out(bo, "docs/occlusion.md")
    bo.add_argument("--quiet", action="store_true", help="no progress bar")


def _add_query(sub: "argparse._SubParsersAction") -> None:
    q = sub.add_parser("query", help="ask a scene a question (docs/reasoning.md): tracks | track T | hidden_by T | "
                                      "holds_at T FRAME | events FROM TO [T] | relation T REL | "
                                      "anticipate T FRAME | situations")
    q.add_argument("scene", help="scene file written by 'refimpl track --scene'")
    q.add_argument("query", nargs="+", help="the query, e.g. hidden_by trk_12")
    q.add_argument("--json", action="store_true", help="print the answer as JSON")
    q.add_argument("--anticipation-threshold", type=int, default=None, metavar="FRAMES",
                   help="warn when a hidden track reappears in front within this many frames (default 30)")
    q.add_argument("--ego-region", default=None, metavar="X0,X1,Y0,Y1",
                   help="the region in front of the ego vehicle, fractions of the image (default 0.333,0.667,0.5,1)")


def _add_explain(sub: "argparse._SubParsersAction") -> None:
    xp = sub.add_parser("explain", help="the event log of a scene as plain English sentences")
    xp.add_argument("scene", help="scene file written by 'refimpl track --scene'")
    xp.add_argument("--track", help="only the episodes of this track (13 or trk_13)")


def _add_plot(sub: "argparse._SubParsersAction") -> None:
    pl = sub.add_parser("plot", help="a space-time picture of a scene, or its boxes and relations at one frame")
    pl.add_argument("scene", help="scene file written by 'refimpl track --scene'")
    pl.add_argument("--out", required=True, help="PNG file to write")
    pl.add_argument("--frame", type=int, help="draw the boxes and relations of this frame instead")
    pl.add_argument("--tracks", help="comma-separated tracks to draw (default: those observed in 3+ frames)")
    pl.add_argument("--frames", metavar="FROM:TO", help="frame range of the space-time picture")


def _add_report(sub: "argparse._SubParsersAction") -> None:
    rp = sub.add_parser("report", help="one self-contained HTML page of a scene: the chosen frame's boxes and their "
                                       "state, the space-time picture, the events per track, the explanations")
    rp.add_argument("scene", help="scene file written by 'refimpl track --scene'")
    rp.add_argument("--out", required=True, help="HTML file to write (- for standard output)")
    rp.add_argument("--frame", type=int, help="the frame shown first (default: the one with the most hidden tracks)")
    rp.add_argument("--images", metavar="DIR",
                    help="the sequence's frames (PNG or JPEG files in name order, the first being the scene's first "
                         "frame, as 'refimpl render' reads them): shown under the boxes, embedded in the page")
    rp.add_argument("--image-frames", metavar="FROM:TO|all",
                    help="with --images: the frames whose images the page carries (default: the frame shown first "
                         "and those near it, docs/reasoning.md 8; each adds 4/3 of its file's size to the page)")


def _add_render(sub: "argparse._SubParsersAction") -> None:
    r = sub.add_parser("render", help="draw a scene on your frames: every track's box, id and state and the "
                                      "frame's abduced events, as images and a video (supervision's annotators)")
    r.add_argument("scene", help="scene file written by 'refimpl track --scene'")
    r.add_argument("--images", required=True, metavar="DIR",
                   help="the sequence's frames, image files in name order, the first being the scene's first frame")
    r.add_argument("--out", required=True, metavar="DIR", help="a new (or empty) folder for one NNNNNN.png per frame")
    r.add_argument("--video", metavar="FILE.mp4|FILE.gif", help="also the frames as a video (PyAV)")
    r.add_argument("--fps", type=_parse_fps, metavar="FPS", help="the video's frame rate (default: the scene's, else 10)")


_COMMANDS = (
    _add_solve,
    _add_track,
    _add_eval,
    _add_benchmark,
    _add_calibrate,
    _add_table6,
    _add_diff,
    _add_sweep,
    _add_demo,
    _add_bench_scale,
    _add_bench_latency,
    _add_bench_peers,
    _add_detectors,
    _add_occlusion_suite,
    _add_bench_occlusion,
    _add_query,
    _add_explain,
    _add_plot,
    _add_report,
    _add_render,
)
"""One function per command, each adding its subparser with its options (the function that runs
it is named in COMMANDS); the order of ``refimpl --help``."""

COMMANDS: dict[str, str] = {
    "solve": "refimpl.cli.solving:cmd_solve",
    "track": "refimpl.cli.tracking:cmd_track",
    "eval": "refimpl.cli.evaluation:cmd_eval",
    "benchmark": "refimpl.cli.benchmarks:cmd_benchmark",
    "calibrate": "refimpl.cli.benchmarks:cmd_calibrate",
    "table6": "refimpl.cli.benchmarks:cmd_table6",
    "diff": "refimpl.cli.solving:cmd_diff",
    "sweep": "refimpl.cli.benchmarks:cmd_sweep",
    "demo": "refimpl.cli.demo:cmd_demo",
    "bench-scale": "refimpl.cli.benchmarks:cmd_bench_scale",
    "bench-latency": "refimpl.cli.benchmarks:cmd_bench_latency",
    "bench-peers": "refimpl.cli.benchmarks:cmd_bench_peers",
    "detectors": "refimpl.cli.benchmarks:cmd_detectors",
    "occlusion-suite": "refimpl.cli.benchmarks:cmd_occlusion_suite",
    "bench-occlusion": "refimpl.cli.benchmarks:cmd_bench_occlusion",
    "query": "refimpl.cli.scenes:cmd_query",
    "explain": "refimpl.cli.scenes:cmd_explain",
    "plot": "refimpl.cli.scenes:cmd_plot",
    "report": "refimpl.cli.scenes:cmd_report",
    "render": "refimpl.cli.scenes:cmd_render",
}
"""The command table: command name -> the function that runs it, as ``"module:function"`` (it takes
the parsed arguments and returns the exit code).  ``main`` loads the function of the command given,
and only that one (refimpl.core.loader), so that ``refimpl track`` imports the tracking path and not
the scorers, the experiments or the scene tools; one module per command group holds the functions."""


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(
        prog="refimpl",
        description="Online visual abduction for multi-object tracking: the paper's ASP model "
                    "and an equivalent CP-SAT model.")
    p.add_argument("--version", action="version", version=f"refimpl {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for add in _COMMANDS:
        add(sub)
    for command in sub.choices.values():
        _show_defaults(command)
    return p


class _DefaultsFormatter(argparse.HelpFormatter):
    """Every option's help ends with its default, unless the help already names it."""

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        shown = action.default not in (None, False, argparse.SUPPRESS) and action.option_strings
        if shown and "default" not in text:
            text = f"{text} (default: %(default)s)" if text else "(default: %(default)s)"
        return text


def _show_defaults(command: argparse.ArgumentParser) -> None:
    """``--help`` of a command shows every default (an option without help text gets a line too)."""
    command.formatter_class = _DefaultsFormatter
    for action in command._actions:
        if action.help is None and action.default not in (None, False) and action.option_strings:
            action.help = "(default: %(default)s)"
