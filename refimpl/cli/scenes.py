"""The commands on a scene file: `query`, `explain`, `plot`, `report` and `render`.

A scene's strings (track ids, types, its name) are the file's: every line printed has its control
characters escaped (refimpl.core.display), so a scene file cannot write to the terminal."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..core.display import visible
from ..io.outputs import STDOUT
from ..scene import explain, load_scene, query, reasoning_config
from ..scene.plots import plot_scene_file
from ..scene.render import render_scene
from ..scene.report_html import write_report
from .common import EXIT_OK, UserError


def cmd_query(args: argparse.Namespace) -> int:
    config = reasoning_config(args.anticipation_threshold, args.ego_region)
    answer = query(load_scene(args.scene), " ".join(args.query), config)
    # JSON escapes every control character itself (\u001b), and must stay the answer's exact strings
    print(answer.to_json() if args.json else "\n".join(map(visible, answer.lines)))
    return EXIT_OK


def cmd_explain(args: argparse.Namespace) -> int:
    print("\n".join(map(visible, explain(load_scene(args.scene), args.track))))
    return EXIT_OK


def cmd_plot(args: argparse.Namespace) -> int:
    print(visible(plot_scene_file(args.scene, args.out, frame=args.frame, tracks=args.tracks, frames=args.frames)))
    return EXIT_OK


def cmd_report(args: argparse.Namespace) -> int:
    summary = write_report(args.scene, args.out, frame=args.frame, images=args.images, frames=args.image_frames)
    print(visible(summary), file=sys.stderr if args.out == STDOUT else sys.stdout)  # the page itself may be stdout
    return EXIT_OK


def cmd_render(args: argparse.Namespace) -> int:
    out = Path(args.out)
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise UserError(f"--out {args.out}: give a new or empty folder (the frames are written into it)")
    if args.video is not None and Path(args.video).resolve().parent == out.resolve():
        raise UserError("--video: write the video beside the --out folder, not into it")
    scene = load_scene(args.scene)
    written, video = render_scene(scene, args.images, out, args.video, args.fps)
    print(visible(f"{scene.name}: {len(written)} frames drawn -> {out}" + (f", {video}" if video else "")))
    return EXIT_OK
