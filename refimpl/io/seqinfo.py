"""MOTChallenge sequences: seqinfo.ini, and the frame and box columns that det.txt and gt.txt share."""

from __future__ import annotations

import configparser
import os
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from ..core.ranges import FPS_RANGE_TEXT, fps_fits
from .errors import InputFormatError
from .lines import (MAX_FRAME, _check_coordinates, _check_integral, _check_max_frame, _check_min_frame,
                    _check_positive_size, _read_lines)


def read_seqinfo(path: str | os.PathLike) -> dict:
    """A MOTChallenge seqinfo.ini as a dict: name, frameRate, seqLength, imWidth, imHeight (+ others as str)."""
    path = Path(path)
    lines = _read_lines(path)  # missing / empty / unreadable
    parser = configparser.ConfigParser(interpolation=None)
    parser.optionxform = str  # keep key case
    try:
        parser.read_string("\n".join(s for _, s in lines), source=str(path))
    except configparser.Error as exc:
        raise InputFormatError(f"not a valid seqinfo.ini: {str(exc).splitlines()[0]}", path) from None
    if not parser.has_section("Sequence"):
        raise InputFormatError("no [Sequence] section", path)
    raw = {k: v.strip() for k, v in parser.items("Sequence")}
    by_lower = {k.lower(): k for k in raw}
    line_of = {}
    for lineno, text in lines:
        key = text.split("=", 1)[0].strip().lower()
        line_of.setdefault(key, lineno)
    out: dict = {k: v for k, v in raw.items()}
    for key, kind in (("name", str), ("frameRate", float), ("seqLength", int),
                      ("imWidth", int), ("imHeight", int)):
        if key.lower() not in by_lower:
            raise InputFormatError(f"missing key {key!r} in [Sequence]", path)
        orig = by_lower[key.lower()]
        text = raw[orig]
        del out[orig]
        try:
            value = kind(text)
        except ValueError:
            raise InputFormatError(f"{key} is not {'an integer' if kind is int else 'a number'}: {text!r}",
                                   path, line_of.get(key.lower())) from None
        # (an int may exceed the float range: np.isfinite would raise TypeError)
        if kind is not str and not (value > 0 and (kind is int or np.isfinite(value))):
            raise InputFormatError(f"{key} must be > 0, got {text!r}", path, line_of.get(key.lower()))
        if key == "frameRate" and not fps_fits(value):
            raise InputFormatError(f"frameRate must be {FPS_RANGE_TEXT}, got {text!r}", path,
                                   line_of.get(key.lower()))
        if kind is str and not value:
            raise InputFormatError(f"{key} is empty", path, line_of.get(key.lower()))
        if key == "seqLength" and value > MAX_FRAME:
            raise InputFormatError(f"seqLength {value} is implausibly large (> {MAX_FRAME})",
                                   path, line_of.get(key.lower()))
        out[key] = value
    return out


def _resolve_seqinfo(seqinfo, data_path: Path) -> dict | None:
    """seqinfo given as a dict or a path, or found at ../seqinfo.ini relative to the file's folder."""
    if isinstance(seqinfo, Mapping):
        missing = [k for k in ("name", "frameRate", "seqLength", "imWidth", "imHeight") if k not in seqinfo]
        if missing:
            raise ValueError(f"seqinfo dict lacks {', '.join(missing)} (use read_seqinfo)")
        return dict(seqinfo)
    if seqinfo is not None:
        return read_seqinfo(seqinfo)
    candidate = data_path.parent.parent / "seqinfo.ini"
    return read_seqinfo(candidate) if candidate.is_file() else None


def _mot_sequence_name(path: Path, info: dict | None) -> str:
    if info is not None:
        return str(info["name"])
    if path.parent.name in ("det", "gt") and path.parent.parent.name:
        return path.parent.parent.name
    return path.stem


def _mot_frames_and_boxes(path: Path, linenos: Sequence[int], a: np.ndarray, info: dict | None,
                          max_frame: int | None = MAX_FRAME):
    """The frame column (integral, 1..seqLength) and the xywh boxes (plausible, positive) of a MOT file."""
    frames = _check_integral(path, linenos, a[:, 0], "frame")
    _check_min_frame(path, linenos, frames, 1, max_frame)
    if info is not None:
        _check_max_frame(path, linenos, frames, info["seqLength"], "seqLength in seqinfo.ini")
    boxes = a[:, 2:6]
    _check_coordinates(path, linenos, boxes, ("x", "y", "w", "h"))
    _check_positive_size(path, linenos, boxes)
    return frames, boxes
