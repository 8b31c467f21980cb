"""Fuzz the scene reader with query / explain / plot, CLI argument values and output paths.

    python tests/tools/fuzz_cli.py [--inputs 600] [--seed 0] [--only I]

The companion of tests/tools/fuzz.py (which fuzzes the fact, MOTChallenge and KITTI readers).  Input
``i`` comes from ``random.Random(f"{seed}/{i}")`` and cycles through three targets:

* ``scene``: a scene file (JSON, tracked from the bundled TUD-Campus sample) with 1 to 3
  mutations of its JSON tree (a value replaced by NaN, inf, a huge or negative number, a string,
  null, a list, a deep nesting; a key deleted; a list reversed, emptied or an item repeated; the
  text truncated or replaced by garbage), then ``query`` (a random query form), ``explain`` or
  ``plot`` through ``refimpl.cli.main``;
* ``args``: a cheap valid command (solve, track --backend baseline, eval, query, explain,
  bench-scale --from-json, demo) with one option value replaced by a hostile one;
* ``paths``: ``track`` or ``plot`` with an output path drawn from: the input itself, a symlink
  or hard link to it, a symlink to a new file, a directory, a missing folder chain, a path
  under a file, ``-``, ``/dev/null``, a 300-character name, an empty string, unicode.

Outcomes: ``ok`` (exit 0 and the output where it should be), ``error`` (exit 2 and one line
``refimpl <command>: error: ...``; argparse's own usage error counts too), and the failures
``traceback`` (any other exception or exit code, or a multi-line error), ``input-changed`` (an
input file's bytes changed), ``leftover`` (a failed command left an output or temporary file),
``missing`` (exit 0 without the output).  Exit 1 on any failure.
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import io as stdio
import json
import math
import os
import random
import shutil
import tempfile
import time
import traceback
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

from refimpl import cli

REPO = Path(__file__).resolve().parents[3]

DEMO = REPO / "data" / "demo" / "TUD-Campus"
BUS = REPO / "data" / "examples" / "bus_t235.lp"
TARGETS = ("scene", "args", "paths")
FAILURES = ("traceback", "input-changed", "leftover", "missing")

HOSTILE_VALUES = ("", " ", "-", "--", "0", "-1", "1e309", "-1e309", "nan", "inf", "2147483648", "9" * 400,
                  "abc", "bogus", ",", ",,", "a,b", "cpsat,cpsat", "baseline,bogus", "1:0", "5:", ":",
                  "x" * 5000, "\u2028", "trk_", "trk_99999", "0.5", "1,2,3,4,5", "/", "/nonexistent/x")
SCENE_VALUES = (float("nan"), float("inf"), -float("inf"), -1, 0, 1e300, 10 ** 400, -(10 ** 30), "", "x",
                None, [], {}, True, [[[[[]]]]], "occurs_at(teleports(trk_1),5)", "occurs_at(lost(_X),5)",
                0.5, 2 ** 31, "trk_1")
QUERIES = (["tracks"], ["track", "{t}"], ["hidden_by", "{t}"], ["holds_at", "{t}", "{f}"], ["events", "{f}", "{g}"],
           ["events", "{f}", "{g}", "{t}"], ["relation", "{t}", "overlapping_top"], ["anticipate", "{t}", "{f}"],
           ["situations"], ["bogus"], ["track"], ["holds_at", "{t}", "x"])


@dataclass
class Result:
    index: int
    target: str
    outcome: str
    detail: str


# ---------------------------------------------------------------------------------------
# Fixtures

def make_fixtures(root: Path) -> dict:
    """A scene of the first 25 TUD-Campus frames (cpsat), a results file, a bench-scale JSON."""
    from refimpl import io
    from refimpl.scene import scene_from_result, scene_to_json
    from refimpl.tracking.pipeline import Setup, run_sequence
    seq = io.read_mot_detections(DEMO / "det" / "det.txt")
    seq = type(seq)(seq.name, seq.frames[:25], seq.first_frame, seq.image_size, seq.fps)
    scene = scene_to_json(scene_from_result(seq, run_sequence(seq, Setup("cpsat"))))
    res = root / "fixture-results.txt"
    with contextlib.redirect_stdout(stdio.StringIO()), contextlib.redirect_stderr(stdio.StringIO()):
        cli.main(["track", "--dets", str(DEMO / "det" / "det.txt"), "--out", str(res)])
    bench = root / "fixture-bench.json"
    bench.write_text(json.dumps({
        "kind": "scale", "runs": [{"backend": "cpsat", "n": 5, "overlap": 0.2, "seed": 0, "ms": 1.0, "optimal": True,
                                   "cost": [[10, -5]], "answer_hash": 1, "error": None}],
        "sizes": [5], "overlaps": [0.2], "seeds": 1, "backends": ["cpsat"], "time_limit": 1.0,
        "machine": "fuzz", "fast_path": {}, "seconds": 0.1}))
    return {"scene": scene, "results": res, "bench": bench}


# ---------------------------------------------------------------------------------------
# Scene mutations

def _slots(node, path=()):
    """Every (container, key) of the JSON tree, to replace or delete."""
    out = []
    if isinstance(node, dict):
        for k, v in node.items():
            out.append((node, k))
            out.extend(_slots(v))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            out.append((node, i))
            out.extend(_slots(v))
    return out


def mutate_scene(scene: dict, rng: random.Random) -> str:
    data = json.loads(json.dumps(scene))
    for _ in range(rng.randint(1, 3)):
        slots = _slots(data)
        kind = rng.random()
        if kind < 0.05:
            return json.dumps(data)[: rng.randint(0, 2000)]
        if kind < 0.07:
            return rng.choice(["", "null", "[]", "{", "\x00\xff", "[" * 5000 + "]" * 5000, '{"format": 1}'])
        if not slots:
            break
        container, key = rng.choice(slots)
        if kind < 0.55:
            container[key] = rng.choice(SCENE_VALUES)
        elif kind < 0.65 and isinstance(container, dict):
            del container[key]
        elif isinstance(container[key], list) and container[key]:
            lst = container[key]
            how = rng.choice(["reverse", "empty", "repeat", "swap"])
            if how == "reverse":
                lst.reverse()
            elif how == "empty":
                lst.clear()
            elif how == "repeat":
                lst.append(lst[rng.randrange(len(lst))])
            elif len(lst) > 1:
                i, j = rng.randrange(len(lst)), rng.randrange(len(lst))
                lst[i], lst[j] = lst[j], lst[i]
        elif isinstance(container[key], (int, float)) and not isinstance(container[key], bool):
            v = container[key]
            container[key] = rng.choice([-v, v * 1000, v + 1, 0, -1]) if math.isfinite(v) else 0
    return json.dumps(data)  # NaN / Infinity are written as JSON extensions, which the reader must face


# ---------------------------------------------------------------------------------------
# Running one command

def _digest(paths) -> dict:
    out = {}
    for p in paths:
        p = Path(p)
        if p.is_file():
            out[str(p)] = hashlib.sha1(p.read_bytes()).hexdigest()
    return out


def run_cli(argv: list[str]) -> tuple[int | None, str, str, str | None]:
    """(exit code, stdout, stderr, traceback text or None) of cli.main in-process."""
    raw = stdio.BytesIO()
    out = stdio.TextIOWrapper(raw, encoding="utf-8", newline="\n")  # with .buffer, as a real stdout
    err = stdio.StringIO()
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = cli.main(argv)
    except SystemExit as exc:  # argparse: usage error
        code = exc.code if isinstance(exc.code, int) else 2
    except BaseException:  # noqa: BLE001 - anything else is what the fuzzer looks for
        return None, "", err.getvalue(), traceback.format_exc(limit=6)
    out.flush()
    return code, raw.getvalue().decode("utf-8", "replace"), err.getvalue(), None


def _files(root: Path) -> set[str]:
    return {str(p) for p in root.rglob("*") if p.is_file() or p.is_symlink()}


def judge(argv, code, err, tb, inputs_before, inputs, out_dir: Path, expect_out: Path | None,
          files_before: set[str]) -> tuple[str, str]:
    command = argv[0]
    if tb is not None:
        return "traceback", tb
    if _digest(inputs) != inputs_before:
        return "input-changed", f"{argv}"
    lines = [line for line in err.splitlines() if line and not line.startswith("refimpl: warning")]
    if code == 0:
        if expect_out is not None and str(expect_out) not in ("-", os.devnull) and not Path(expect_out).exists():
            return "missing", f"{argv}"
        return "ok", ""
    if code != 2:
        return "traceback", f"exit {code}: {err[-400:]}"
    usage = lines and lines[0].startswith("usage:")
    errors = [line for line in lines if not line.startswith("usage:") and not line.startswith(" ")]
    if len(errors) != 1 or not (errors[0].startswith(f"refimpl {command}: error:")
                                or (usage and ": error:" in errors[0])):
        return "traceback", f"not one error line: {err[-400:]!r}"
    left = sorted(_files(out_dir) - files_before)
    if left:
        return "leftover", f"{argv}: {left}"
    return "error", errors[0][:160]


# ---------------------------------------------------------------------------------------
# The three targets

def case_scene(rng: random.Random, fx: dict, work: Path) -> tuple[list[str], list, Path | None]:
    path = work / "scene.json"
    path.write_text(mutate_scene(fx["scene"], rng), encoding="utf-8", errors="surrogatepass")
    t, f, g = rng.choice(["trk_1", "trk_2", "5", "trk_999", "x"]), rng.choice(["3", "10", "-5", "99999"]), \
        rng.choice(["20", "1", "x"])
    pick = rng.random()
    if pick < 0.5:
        q = [w.format(t=t, f=f, g=g) for w in rng.choice(QUERIES)]
        return ["query", str(path), *q] + (["--json"] if rng.random() < 0.3 else []), [path], None
    if pick < 0.85:
        return ["explain", str(path)] + (["--track", t] if rng.random() < 0.5 else []), [path], None
    out = work / "out.png"
    extra = rng.choice([[], ["--frame", f], ["--frames", f"{f}:{g}"], ["--tracks", t]])
    return ["plot", str(path), "--out", str(out), *extra], [path], out


def case_args(rng: random.Random, fx: dict, work: Path) -> tuple[list[str], list, Path | None]:
    dets, gt = DEMO / "det" / "det.txt", DEMO / "gt" / "gt.txt"
    scene = work / "scene.json"
    scene.write_text(json.dumps(fx["scene"]))
    out = work / "out.txt"
    bases = [
        (["solve", str(BUS), "--backend", "cpsat"], ["--backend", "--time-limit", "--const"], [BUS], None),
        (["track", "--dets", str(dets), "--backend", "baseline", "--out", str(out)],
         ["--format", "--class", "--backend", "--scores", "--out-format", "--img-size"], [dets], out),
        (["eval", str(fx["results"]), "--gt", str(gt)], ["--format", "--class"], [fx["results"], gt], None),
        (["query", str(scene), "holds_at", "trk_1", "5"], ["--anticipation-threshold", "--ego-region"], [scene], None),
        (["explain", str(scene)], ["--track"], [scene], None),
        (["bench-scale", "--from-json", str(fx["bench"]), "--out", "-", "--quiet"],
         ["--sizes", "--overlaps", "--seeds", "--backends", "--trackers", "--time-limit"], [fx["bench"]], None),
        (["demo"], ["--backends"], [], None),
        (["table6", "--datasets", "bogus"], ["--datasets", "--backend"], [], None),
    ]
    argv, options, inputs, expect = rng.choice(bases)
    option = rng.choice(options)
    value = rng.choice(HOSTILE_VALUES)
    if option == "--const":
        value = rng.choice(["iou_thresh=" + value, value, "_=1", "not=2", "img_width=-" + value])
    if argv[0] == "demo" and value not in ("bogus", "baseline,bogus", "", ",", ",,", "-", "--"):
        value = "bogus"  # a valid --backends would run the whole demo: keep the fuzz cheap
    if argv[0] == "table6" and option == "--backend":
        argv = argv  # --backend is validated by argparse choices; --datasets bogus stops before any work
    if argv[0] == "bench-scale" and option in ("--sizes", "--overlaps", "--seeds", "--backends", "--time-limit"):
        pass  # --from-json is given: nothing is solved whatever the value
    return argv + [f"{option}={value}"], inputs, expect


def case_paths(rng: random.Random, fx: dict, work: Path) -> tuple[list[str], list, Path | None]:
    src = work / "in"
    src.mkdir(exist_ok=True)
    dets = src / "det.txt"
    if not dets.exists():
        shutil.copy(DEMO / "det" / "det.txt", dets)
    scene = src / "scene.json"
    if not scene.exists():
        scene.write_text(json.dumps(fx["scene"]))
    out_dir = work / "o"
    out_dir.mkdir(exist_ok=True)
    command = rng.choice(["track", "track", "plot"])
    inp = dets if command == "track" else scene
    kind = rng.choice(["input", "symlink-input", "hardlink-input", "symlink-new", "directory", "missing-folders",
                       "under-file", "dash", "devnull", "long", "empty", "unicode", "plain", "same-twice"])
    out: Path | str
    if kind == "input":
        out = inp
    elif kind == "symlink-input":
        out = out_dir / "out-link"
        out.symlink_to(inp)
    elif kind == "hardlink-input":
        out = out_dir / "out-hard"
        os.link(inp, out)
    elif kind == "symlink-new":
        out = out_dir / "out-link-new"
        out.symlink_to(out_dir / "out-target")
    elif kind == "directory":
        out = out_dir
    elif kind == "missing-folders":
        out = out_dir / "a" / "b" / "out.txt"
    elif kind == "under-file":
        out = inp / "out.txt"
    elif kind == "dash":
        out = "-"
    elif kind == "devnull":
        out = os.devnull
    elif kind == "long":
        out = out_dir / ("o" * 300)
    elif kind == "empty":
        out = ""
    elif kind == "unicode":
        out = out_dir / "out-\u00e9\u4e2d \u2028.txt"
    else:
        out = out_dir / "out.txt"
    if command == "track":
        argv = ["track", "--dets", str(dets), "--backend", "baseline", "--out", str(out)]
        if kind == "same-twice":
            argv += ["--events", str(out)]
        elif rng.random() < 0.3:
            argv += ["--events", str(rng.choice([out_dir / "out-ev.lp", dets, "-"]))]
    else:
        argv = ["plot", str(scene), "--out", str(out)]
    expect = None if kind in ("dash", "devnull") else Path(os.path.realpath(out)) if out else None
    return argv, [dets, scene], expect


CASES = {"scene": case_scene, "args": case_args, "paths": case_paths}


def run_one(seed: int, index: int, fx: dict, root: Path) -> Result:
    rng = random.Random(f"{seed}/{index}")
    target = TARGETS[index % len(TARGETS)]
    work = Path(tempfile.mkdtemp(dir=root, prefix=f"{index}-"))
    try:
        argv, inputs, expect = CASES[target](rng, fx, work)
        before, files = _digest(inputs), _files(work)
        code, _, err, tb = run_cli(argv)
        outcome, detail = judge(argv, code, err, tb, before, inputs, work, expect, files)
        return Result(index, target, outcome, detail)
    finally:
        shutil.rmtree(work, ignore_errors=True)


def run(inputs: int, seed: int = 0, only: int | None = None) -> list[Result]:
    root = Path(tempfile.mkdtemp(prefix="refimpl-fuzz-cli-"))
    try:
        fx = make_fixtures(root)
        indices = [only] if only is not None else range(inputs)
        return [run_one(seed, i, fx, root) for i in indices]
    finally:
        shutil.rmtree(root, ignore_errors=True)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--inputs", type=int, default=600)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--only", type=int, help="run input I only (reproduce a failure)")
    args = ap.parse_args()
    start = time.perf_counter()
    results = run(args.inputs, args.seed, args.only)
    counts = Counter((r.target, r.outcome) for r in results)
    outcomes = ("ok", "error") + FAILURES
    print("| target | " + " | ".join(outcomes) + " | total |")
    print("|---|" + "---:|" * (len(outcomes) + 1))
    for t in TARGETS:
        row = [counts[(t, o)] for o in outcomes]
        print(f"| {t} | " + " | ".join(map(str, row)) + f" | {sum(row)} |")
    bad = [r for r in results if r.outcome in FAILURES]
    for r in bad[:10]:  # reproduce one with --only INDEX
        print(f"\n{r.outcome}: input {r.index} ({r.target})\n{r.detail}")
    print(f"\n{len(results)} inputs in {time.perf_counter() - start:.0f} s, {len(bad)} failures")
    return 1 if bad else 0
