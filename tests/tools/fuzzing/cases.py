"""One fuzz input: generated from its seed and index, written to a folder, read by its target's
reader, and its outcome classified."""

from __future__ import annotations

import contextlib
import random
import re
import signal
import time
import traceback
import warnings
from dataclasses import dataclass, field
from pathlib import Path

from refimpl import io as rio

from .mutations import _OPS, _WEIGHTS, Doc, m_delete_line, m_dup_line, m_replace_number, m_truncate_line, m_whitespace
from .readers import FILE_LEVEL, TARGETS, CheckFailed
from .seeds import Seeds

OUTCOMES = ("accepted", "error", "traceback", "bad-error", "bad-accept", "leftover", "timeout")
FAILURES = OUTCOMES[2:]


@dataclass
class Case:
    index: int
    target: str
    seed_name: str
    mutations: list[str]
    data: bytes
    layout: str = "flat"
    side: dict = field(default_factory=dict)  # extra files: relative path -> bytes
    cli: bool = False
    backend: str = "baseline"  # tracker of a CLI track run (solve: clingo for "cpsat", else cpsat)


@dataclass
class Result:
    case: Case
    kind: str  # "reader" or "cli"
    outcome: str
    detail: str = ""
    seconds: float = 0.0


def generate(seeds: Seeds, seed: int, index: int, cli_every: int) -> Case:
    rng = random.Random(f"{seed}/{index}")
    target = TARGETS[index % len(TARGETS)]
    name, text = rng.choice(getattr(seeds, target.name))
    doc = Doc(text.splitlines(), target.sep)
    mutations = []
    if rng.random() >= 0.04:  # a few unmutated seeds keep the "accepted" path exercised
        for _ in range(rng.choice((1, 1, 1, 2, 2, 3, 4))):
            mutations.append(rng.choices(_OPS, _WEIGHTS)[0](doc, rng))
    # every cli_every-th group of len(TARGETS) consecutive inputs (one per target) also runs the CLI
    case = Case(index, target.name, name, mutations or ["none"], doc.to_bytes(),
                cli=cli_every > 0 and (index // len(TARGETS)) % cli_every == 0)
    if target.name in ("mot_det", "mot_gt") and rng.random() < 0.3:
        case.layout = "seq"  # seq/{det,gt}/file.txt with seq/seqinfo.ini beside
        info = seeds.seqinfo
        if rng.random() < 0.3:
            sdoc = Doc(info.splitlines(), "=")
            for op in (m_replace_number, m_delete_line, m_truncate_line, m_dup_line, m_whitespace):
                if rng.random() < 0.3:
                    case.mutations.append("seqinfo: " + op(sdoc, rng))
            info = sdoc.to_bytes().decode("utf-8", errors="replace")
        case.side["seqinfo.ini"] = info.encode("utf-8")
    if target.name == "kitti_det" and name == "0000.txt" and rng.random() < 0.3:
        case.layout = "kitti"  # det_02/Car/0000.txt with label_02/0000.txt (its frame count)
        ldoc = Doc(seeds.kitti_label_text.splitlines(), " ")
        if rng.random() < 0.3:
            case.mutations.append("label: " + rng.choices(_OPS, _WEIGHTS)[0](ldoc, rng))
        case.side["label"] = ldoc.to_bytes()
    case.backend = rng.choice(("baseline", "cpsat"))
    return case


def _paths(case: Case, root: Path) -> Path:
    """Write the case under root; return the input file's path."""
    if case.layout == "seq":
        sub = "det" if case.target == "mot_det" else "gt"
        path = root / "seq" / sub / f"{case.target}.txt"
        path.parent.mkdir(parents=True)
        (root / "seq" / "seqinfo.ini").write_bytes(case.side["seqinfo.ini"])
    elif case.layout == "kitti":
        path = root / "det_02" / "Car" / "0000.txt"
        path.parent.mkdir(parents=True)
        (root / "label_02").mkdir()
        (root / "label_02" / "0000.txt").write_bytes(case.side["label"])
    else:
        path = root / ("input.lp" if case.target == "facts" else f"{case.target}.txt")
    path.write_bytes(case.data)
    return path


def _physical_lines(data: bytes) -> list[str]:
    text = data.decode("utf-8-sig", errors="replace")
    return re.split(r"\r\n|\r|\n", text)


def classify_error(exc: BaseException, path: Path, data: bytes, files: dict[str, bytes]) -> tuple[str, str]:
    """'error' for a clean one-line error naming file (and line), else 'bad-error' / 'traceback'."""
    msg = str(exc)
    if len(msg.splitlines()) != 1 or msg != msg.strip():
        return "traceback", f"multi-line error message: {msg[:300]!r}"
    source = getattr(exc, "source", None) or getattr(exc, "path", None)
    line = getattr(exc, "line", None)
    if source is None or not msg.startswith(str(source)):
        return "bad-error", f"message does not start with the file name: {msg[:200]!r}"
    named = files.get(str(source))
    if named is None:
        return "bad-error", f"names an unexpected file {source!r}: {msg[:200]!r}"
    reason = getattr(exc, "reason", msg)
    if line is None:
        if not any(reason.startswith(p) for p in FILE_LEVEL) and "not a valid seqinfo.ini" not in reason \
                and "in [Sequence]" not in reason and "no [Sequence] section" not in reason:
            return "bad-error", f"names no line: {msg[:200]!r}"
        return "error", msg
    if not msg.startswith(f"{source}:{line}: "):
        return "bad-error", f"message does not start with file:line: {msg[:200]!r}"
    lines = _physical_lines(named)
    if not (isinstance(line, int) and 1 <= line <= len(lines)) or not lines[line - 1].strip():
        return "bad-error", f"line {line} is not a non-blank line of the file ({len(lines)} lines): {msg[:200]!r}"
    return "error", msg


class _Timeout(Exception):
    pass


@contextlib.contextmanager
def _time_limit(seconds: float):
    if seconds <= 0 or not hasattr(signal, "setitimer"):
        yield
        return

    def handler(signum, frame):
        raise _Timeout()

    old = signal.signal(signal.SIGALRM, handler)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


def case_files(case: Case, root: Path) -> tuple[Path, dict[str, bytes]]:
    """Write the case under root: its input file's path, and every file it wrote (path -> bytes),
    side files included, for checking that nothing was modified."""
    path = _paths(case, root)
    files = {str(path): case.data}
    if case.layout == "seq":
        files[str(root / "seq" / "seqinfo.ini")] = case.side["seqinfo.ini"]
    if case.layout == "kitti":
        files[str(root / "label_02" / "0000.txt")] = case.side["label"]
    return path, files


def run_reader(case: Case, root: Path, timeout: float) -> Result:
    target = next(t for t in TARGETS if t.name == case.target)
    path, files = case_files(case, root)
    ctx: dict = {"class": "pedestrian" if case.seed_name.startswith("ped") else "car",
                 "first_frame": 0 if case.seed_name.startswith("kitti") else 1}
    if case.layout == "seq":
        try:
            ctx["seqinfo"] = rio.read_seqinfo(root / "seq" / "seqinfo.ini")["seqLength"]
        except Exception:  # noqa: BLE001 - the reader call below reports it
            ctx["seqinfo"] = None
    t0 = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", RuntimeWarning)  # numpy overflow / invalid casts
            with _time_limit(timeout):
                target.reader(path, case.data, ctx)
        outcome, detail = "accepted", ""
    except _Timeout:
        outcome, detail = "timeout", f"no answer within {timeout:g} s"
    except CheckFailed as exc:
        outcome, detail = "bad-accept", str(exc)
    except target.errors as exc:
        outcome, detail = classify_error(exc, path, case.data, files)
        if outcome == "traceback":
            detail += "\n" + "".join(traceback.format_exception(exc))
    except Exception as exc:  # noqa: BLE001 - the point of a fuzzer
        outcome, detail = "traceback", "".join(traceback.format_exception(exc))[-4000:]
    return Result(case, "reader", outcome, detail, time.perf_counter() - t0)
