"""The frame images a scene report shows under its boxes (``refimpl report --images DIR``).

Which file is which frame is ``refimpl render``'s rule, read from it (refimpl.scene.render.frame_images:
the folder's images in name order, the first being the scene's first frame).  The page embeds the
images as they are, PNG or JPEG bytes in data URIs (base64: 4/3 of the file's size), so it stays one
self-contained file; nothing is decoded or re-encoded, and no image library is needed.  Only the frames
the page is told to carry are read: by default the frame shown first and the ``IMAGE_WINDOW`` frames
before and after it, or a range ``FROM:TO`` (``all``: every frame of the scene).

Each image's width and height are read from its header (PNG's IHDR, JPEG's start-of-frame), so an image
that is neither, is cut short, or does not have the scene's image size is a one-line SceneError: boxes
drawn on a picture of another size would be silently misplaced.
"""

from __future__ import annotations

import base64
import os
import struct
from dataclasses import dataclass

from .model import Scene, SceneError
from .render import frame_images

IMAGE_WINDOW = 25
"""By default the page carries the images of its first frame and of the 25 frames either side (51)."""

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
_JPEG_SOF = {0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF}
"""JPEG start-of-frame markers (the one that holds the size); C4, C8, CC are other segments."""


@dataclass(frozen=True)
class FrameImage:
    frame: int
    mime: str
    width: int
    height: int
    data: bytes
    """The file's bytes, as they are."""

    def data_uri(self) -> str:
        return f"data:{self.mime};base64," + base64.b64encode(self.data).decode("ascii")


def _jpeg_size(data: bytes) -> tuple[int, int] | None:
    i = 2
    while i + 4 <= len(data):
        if data[i] != 0xFF:
            return None
        marker = data[i + 1]
        if marker == 0xFF:  # fill byte
            i += 1
            continue
        if marker == 0x01 or 0xD0 <= marker <= 0xD9:  # markers without a length
            i += 2
            continue
        length = struct.unpack(">H", data[i + 2:i + 4])[0]
        if marker in _JPEG_SOF:
            if i + 9 > len(data):
                return None
            height, width = struct.unpack(">HH", data[i + 5:i + 9])
            return width, height
        i += 2 + length
    return None


def image_header(data: bytes) -> tuple[str, int, int] | None:
    """(MIME type, width, height) of PNG or JPEG bytes, None for anything else."""
    if data.startswith(PNG_SIGNATURE) and len(data) >= 24 and data[12:16] == b"IHDR":
        width, height = struct.unpack(">II", data[16:24])
        return "image/png", width, height
    if data.startswith(b"\xff\xd8\xff"):
        size = _jpeg_size(data)
        return ("image/jpeg", *size) if size else None
    return None


def image_frames(scene: Scene, shown: int, frames: str | None) -> tuple[int, int]:
    """The first and last frame whose image the page carries (module doc); frames: None, 'all' or FROM:TO."""
    lo, hi = scene.first_frame, scene.last_frame
    if frames is None:
        return max(lo, shown - IMAGE_WINDOW), min(hi, shown + IMAGE_WINDOW)
    if frames == "all":
        return lo, hi
    a, sep, b = frames.partition(":")
    try:
        first, last = int(a) if a else lo, int(b) if b else hi
    except ValueError:
        sep = ""
    if not sep or first > last:
        raise SceneError(f"--image-frames must be all or FROM:TO with FROM <= TO, got {frames!r}")
    if first < lo or last > hi:
        raise SceneError(f"--image-frames {frames}: the scene's frames are {lo}..{hi}")
    return first, last


def load_frame_images(folder: str | os.PathLike, scene: Scene, first: int, last: int) -> tuple[FrameImage, ...]:
    """The images of frames first..last (refimpl render's files), read and checked (module doc)."""
    files = frame_images(folder, scene)
    out = []
    for frame in range(first, last + 1):
        path = files[frame - scene.first_frame]
        try:
            data = path.read_bytes()
        except OSError as exc:
            raise SceneError(f"--images: cannot read {path} (frame {frame}): {exc.strerror or exc}") from None
        header = image_header(data)
        if header is None:
            raise SceneError(f"--images: {path} (frame {frame}) is not a readable PNG or JPEG image; the report "
                             "embeds PNG and JPEG files as they are")
        mime, width, height = header
        if scene.image_size and (width, height) != tuple(scene.image_size):
            raise SceneError(f"--images: {path} (frame {frame}) is {width} x {height} px, but scene {scene.name} "
                             f"is {scene.image_size[0]} x {scene.image_size[1]} px")
        out.append(FrameImage(frame, mime, width, height, data))
    return tuple(out)
