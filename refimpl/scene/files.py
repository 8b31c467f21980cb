"""Scene files: a scene as JSON (the ``refimpl-scene`` format), validated on reading.

Everything query / explain / plot rely on is checked when a file is read; a malformed or
unreadable file is a one-line :class:`SceneError` naming the file.
"""

from __future__ import annotations

import json
import math
import os

from ..core import bigint
from ..core.spec import HistoryEvent, ProblemFormatError
from ..core.facts import parse_term
from ..core.records import RecordTooLong, read_text
from ..io import write_text_atomic
from ..knowledge.event_table import EFFECTS
from .model import Box, Scene, SceneError, SceneTrack


SCENE_FORMAT = "refimpl-scene"
SCENE_VERSION = 1


def scene_to_json(scene: Scene) -> dict:
    """The scene as a JSON-ready dict (the file format of :func:`save_scene`)."""
    return {
        "format": SCENE_FORMAT,
        "version": SCENE_VERSION,
        "name": scene.name,
        "image_size": list(scene.image_size) if scene.image_size else None,
        "fps": scene.fps,
        "first_frame": scene.first_frame,
        "last_frame": scene.last_frame,
        "tracks": [{"id": t.id, "type": t.type,
                    "observed": [[f, *b] for f, b in t.observed],
                    "halted": [[f, *b] for f, b in t.halted],
                    "ended_at": t.ended_at} for t in scene.tracks],
        "events": [str(e) for e in scene.events],
        "timelines": {k: [list(i) for i in v] for k, v in scene.timelines},
    }


def _need(cond: bool, what: str) -> None:
    if not cond:
        raise SceneError(what)


SCENE_MAX_INT = 2 ** 63 - 1
"""No number of a scene (frame, pixel, size) is larger; a larger integer is refused on reading."""


def _scene_int(text: str) -> int:
    """An integer of the file, read whatever its length (refimpl.core.bigint), refused beyond
    SCENE_MAX_INT with its number of digits (the messages below print the values they check)."""
    value = bigint.parse_int(text)
    if abs(value) > SCENE_MAX_INT:
        raise SceneError(f"not a refimpl scene file (an integer of {len(text.lstrip('-+'))} digits; "
                         f"a scene's frames and pixels are below 2^63)")
    return value


def _int(v, what: str) -> int:
    _need(isinstance(v, int) and not isinstance(v, bool), f"{what} must be an integer, got {v!r}")
    return v


SCENE_MAX_COORD = 1_000_000.0
"""Box coordinates and sizes beyond this magnitude (pixels) are refused, as in refimpl.io."""
SCENE_MAX_IMAGE = 100_000
"""image_size entries must be 1..SCENE_MAX_IMAGE pixels."""


def _boxes(rows, what: str) -> tuple[tuple[int, Box], ...]:
    """[frame, x, y, w, h] rows: frames strictly increasing, finite coordinates, positive sizes."""
    _need(isinstance(rows, list), f"{what} must be a list")
    out = []
    for row in rows:
        _need(isinstance(row, list) and len(row) == 5
              and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in row),
              f"{what}: each entry must be [frame, x, y, w, h], got {row!r:.80}")
        frame = _int(row[0], f"{what}: frame")
        _need(all(abs(v) <= SCENE_MAX_COORD or v != v for v in row[1:]),  # (NaN is caught below)
              f"{what}: frame {frame}: box coordinates must be finite numbers within +-{SCENE_MAX_COORD:g}")
        box = tuple(float(v) for v in row[1:])
        _need(all(math.isfinite(v) and abs(v) <= SCENE_MAX_COORD for v in box),
              f"{what}: frame {frame}: box coordinates must be finite numbers within +-{SCENE_MAX_COORD:g}, "
              f"got {list(box)}")
        _need(box[2] > 0 and box[3] > 0, f"{what}: frame {frame}: box width and height must be > 0, got {list(box)}")
        _need(not out or frame > out[-1][0],
              f"{what}: frames must be strictly increasing, got {frame} after {out[-1][0] if out else ''}")
        out.append((frame, box))
    return tuple(out)  # type: ignore[return-value]


def _event(text, i: int) -> HistoryEvent:
    _need(isinstance(text, str), f"events[{i}] must be a string 'occurs_at(E,T)'")
    try:
        term = parse_term(text)
    except ProblemFormatError as exc:
        raise SceneError(f"events[{i}]: {exc.reason}") from None
    _need(term.name == "occurs_at" and len(term.args) == 2 and term.args[1].is_int,
          f"events[{i}] is not occurs_at(E,T): {text!r:.80}")
    event = term.args[0]
    known = EFFECTS.get(event.name)
    _need(known is not None, f"events[{i}]: unknown event {event.name!r} (known: {', '.join(EFFECTS)})")
    _need(len(event.args) == known[0] and all(not a.args and not a.is_int for a in event.args),
          f"events[{i}]: {event.name} takes {known[0]} track id(s), got {text!r:.80}")
    return HistoryEvent(event, term.args[1].as_int())


def _check_scene(scene: "Scene") -> None:
    """Everything query / explain / plot rely on, beyond the types (SceneError otherwise)."""
    lo, hi = scene.first_frame, scene.last_frame
    _need(lo <= hi, f"first_frame {lo} is after last_frame {hi}")
    if scene.image_size is not None:
        _need(all(1 <= v <= SCENE_MAX_IMAGE for v in scene.image_size),
              f"image_size must be two sizes 1..{SCENE_MAX_IMAGE}, got {list(scene.image_size)}")
    _need(scene.fps is None or (math.isfinite(scene.fps) and scene.fps > 0), f"fps must be > 0, got {scene.fps}")
    seen: set[str] = set()
    for t in scene.tracks:
        _need(t.id not in seen, f"duplicate track id {t.id!r}")
        seen.add(t.id)
        _need(bool(t.observed), f"track {t.id} has no observed box (every track starts with one)")
        frames = [f for f, _ in t.observed] + [f for f, _ in t.halted]
        _need(all(lo <= f <= hi for f in frames), f"track {t.id} has a box outside frames {lo}..{hi}")
        _need(len(set(frames)) == len(frames), f"track {t.id} is both observed and halted in one frame")
        if t.ended_at is not None:
            _need(t.observed[-1][0] <= t.ended_at <= hi,
                  f"track {t.id} ends at {t.ended_at}, before its last observation or after last_frame")
    last = None
    for i, e in enumerate(scene.events):
        _need(lo <= e.time <= hi, f"events[{i}] {e} is outside frames {lo}..{hi}")
        _need(last is None or e.time >= last, f"events[{i}] {e} is out of time order")
        last = e.time
    for k, v in scene.timelines:
        _need(all(a <= b for a, b, _ in v), f"timelines[{k!r}]: an interval ends before it starts")


def scene_from_json(data) -> Scene:
    """Inverse of :func:`scene_to_json`; SceneError (without the file name) on anything malformed."""
    _need(isinstance(data, dict), "the top level must be a JSON object")
    _need(data.get("format") == SCENE_FORMAT, f"not a refimpl scene (\"format\" is {data.get('format')!r},"
          f" expected {SCENE_FORMAT!r})")
    _need(data.get("version") == SCENE_VERSION, f"unsupported scene version {data.get('version')!r}"
          f" (this refimpl reads version {SCENE_VERSION})")
    for key in ("name", "first_frame", "last_frame", "tracks", "events", "timelines"):
        _need(key in data, f"missing field {key!r}")
    _need(isinstance(data["name"], str), "name must be a string")
    size = data.get("image_size")
    _need(size is None or (isinstance(size, list) and len(size) == 2 and all(isinstance(v, int) for v in size)),
          f"image_size must be [width, height] or null, got {size!r}")
    fps = data.get("fps")
    _need(fps is None or (isinstance(fps, (int, float)) and not isinstance(fps, bool)), "fps must be a number or null")
    _need(isinstance(data["tracks"], list), "tracks must be a list")
    tracks = []
    for i, t in enumerate(data["tracks"]):
        _need(isinstance(t, dict) and isinstance(t.get("id"), str) and isinstance(t.get("type"), str),
              f"tracks[{i}] must be an object with string id and type")
        ended = t.get("ended_at")
        tracks.append(SceneTrack(t["id"], t["type"], _boxes(t.get("observed"), f"tracks[{i}].observed"),
                                 _boxes(t.get("halted", []), f"tracks[{i}].halted"),
                                 None if ended is None else _int(ended, f"tracks[{i}].ended_at")))
    _need(isinstance(data["events"], list), "events must be a list")
    events = tuple(_event(e, i) for i, e in enumerate(data["events"]))
    lines = data["timelines"]
    _need(isinstance(lines, dict), "timelines must be an object")
    timelines = []
    for k, v in lines.items():
        _need(isinstance(v, list) and all(isinstance(i, list) and len(i) == 3 and isinstance(i[0], int)
                                          and isinstance(i[1], int) and isinstance(i[2], str) for i in v),
              f"timelines[{k!r}] must be a list of [from_frame, to_frame, value]")
        timelines.append((k, tuple((i[0], i[1], i[2]) for i in v)))
    scene = Scene(data["name"], tuple(size) if size is not None else None, _int(data["first_frame"], "first_frame"),
                  _int(data["last_frame"], "last_frame"), None if fps is None else float(fps),
                  tuple(tracks), events, tuple(timelines))
    _check_scene(scene)
    return scene


def save_scene(path: str | os.PathLike, scene: Scene) -> None:
    """Write the scene as JSON, atomically (a temporary file in the same folder, then a rename)."""
    write_text_atomic(path, json.dumps(scene_to_json(scene), separators=(",", ":")) + "\n")


def load_scene(path: str | os.PathLike) -> Scene:
    """Read a scene file; a missing, unreadable or malformed file is a SceneError naming the file."""
    path = os.fspath(path)
    try:
        data = json.loads(read_text(path), parse_int=_scene_int)
    except RecordTooLong as exc:
        raise SceneError(f"{path}: {exc}") from None
    except FileNotFoundError:
        raise SceneError(f"{path}: no such scene file") from None
    except UnicodeDecodeError:
        raise SceneError(f"{path}: not a refimpl scene file (not UTF-8 text)") from None
    except json.JSONDecodeError as exc:
        raise SceneError(f"{path}: not a refimpl scene file (invalid JSON at line {exc.lineno}"
                         f" column {exc.colno}: {exc.msg})") from None
    except RecursionError:
        raise SceneError(f"{path}: not a refimpl scene file (JSON nested too deeply)") from None
    except SceneError as exc:  # an integer beyond SCENE_MAX_INT
        raise SceneError(f"{path}: {exc}") from None
    except ValueError as exc:
        raise SceneError(f"{path}: not a refimpl scene file ({str(exc).splitlines()[0][:80]})") from None
    except OSError as exc:
        raise SceneError(f"{path}: cannot read: {exc.strerror or exc}") from None
    try:
        return scene_from_json(data)
    except SceneError as exc:
        raise SceneError(f"{path}: {exc}") from None
