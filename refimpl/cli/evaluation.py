"""The `eval` command: results files scored against ground truth, by either devkit."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from .. import io
from ..evaluation.devkits import check_devkit, evaluate_sequences
from ..evaluation.evaluate import format_table
from ..evaluation.folder_eval import load_folder, load_sequence, metrics_json
from ..io.outputs import check_outputs
from .common import EXIT_OK, UserError


def cmd_eval(args: argparse.Namespace) -> int:
    check_outputs({"--json": args.json}, {"results": args.results, "--gt": args.gt})
    if io.get_format(args.format).needs_class and args.cls is None:
        raise UserError(f"--format {args.format} needs --class Car|Pedestrian|Cyclist")
    try:
        check_devkit(args.devkit, args.format, args.cls)
    except ValueError as exc:
        raise UserError(str(exc)) from None
    if Path(args.results).is_dir():
        sequences, unscored = load_folder(args.results, args.gt, args.format, args.cls)
        if unscored:
            print(f"refimpl eval: note: {len(unscored)} ground-truth sequence(s) without a results file "
                  f"not scored: {', '.join(unscored)}", file=sys.stderr)
    else:
        if Path(args.gt).is_dir():
            raise UserError(f"{args.gt}: with one results file, --gt is that sequence's ground-truth file")
        sequences = [load_sequence(None, args.results, args.gt, args.format, args.cls, allow_empty=True)]
        if not len(sequences[0].results):  # as TrackEval scores a tracker that wrote nothing: every target missed
            print(f"refimpl eval: note: {args.results} holds no rows: scored as no tracks (every target missed)",
                  file=sys.stderr)
    scores = evaluate_sequences(sequences, args.format, args.cls, args.devkit)
    print(scores.header)
    print(format_table(scores.per_sequence, scores.overall))
    if args.json:
        report = {"devkit": scores.devkit, "convention": scores.convention,
                  **metrics_json(scores.per_sequence, scores.overall)}
        io.write_text_atomic(args.json, json.dumps(report, indent=2) + "\n")
    return EXIT_OK
