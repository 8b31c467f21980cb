"""A scene drawn on the user's own frames: every track's box with its id and state, and the events
abduced at that frame, as one image per frame and a video (``refimpl render``).

The frames are the image files of a folder (``.jpg``, ``.jpeg``, ``.png``, ``.bmp``) in name
order, the first being the scene's first frame (MOTChallenge's ``img1/000001.jpg`` is frame 1,
KITTI's ``image_02/NNNN/000000.png`` frame 0); the folder must hold at least as many as the
scene has frames.  A box the tracker observed is drawn in one colour, a halted one (its Kalman
prediction while hidden, missed, ...) in another with its state (``5 hidden by 3``).  The boxes
and labels are supervision's annotators; the frames are read and written with Pillow and the
video (MPEG-4 ``.mp4``, or a ``.gif``) with PyAV.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from .model import Scene, SceneError
from .report import ACTIVE, frame_states

IMAGE_SUFFIXES = (".jpg", ".jpeg", ".png", ".bmp")
VIDEO_SUFFIXES = {".mp4": ("mpeg4", "yuv420p"), ".gif": ("gif", "rgb8")}
"""Video file suffix -> (PyAV codec, pixel format)."""


def frame_images(folder: str | os.PathLike, scene: Scene) -> list[Path]:
    """The image of every frame of the scene, first to last (module doc); SceneError (one sentence)
    for a folder that is missing or holds too few images."""
    path = Path(folder)
    if not path.is_dir():
        raise SceneError(f"--images {folder}: not a folder of frame images")
    images = sorted(p for p in path.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES and p.is_file())
    count = scene.last_frame - scene.first_frame + 1
    if len(images) < count:
        raise SceneError(f"--images {folder}: {len(images)} image(s) ({', '.join(IMAGE_SUFFIXES)}), but scene "
                         f"{scene.name} has {count} frames ({scene.first_frame}..{scene.last_frame})")
    return images[:count]


def _labels(states) -> list[str]:
    out = []
    for s in states:
        number = s.track.rsplit("_", 1)[-1]
        if s.state == ACTIVE:
            out.append(number)
        else:
            by = f" by {s.hidden_by.rsplit('_', 1)[-1]}" if s.hidden_by else ""
            out.append(f"{number} {s.state}{by}")
    return out


def draw_frame(image: np.ndarray, states, events: list[str]) -> np.ndarray:
    """The frame (H x W x 3, RGB) with the boxes of ``states`` (refimpl.scene.report.BoxState), their
    labels, and the frame's events written top left."""
    import supervision as sv
    out = np.ascontiguousarray(image[:, :, ::-1])  # supervision draws on OpenCV's BGR order
    if states:
        xyxy = np.array([[b.box[0], b.box[1], b.box[0] + b.box[2], b.box[1] + b.box[3]] for b in states], dtype=float)
        detections = sv.Detections(xyxy=xyxy, class_id=np.array([0 if s.state == ACTIVE else 1 for s in states]))
        palette = sv.ColorPalette([sv.Color(r=0, g=200, b=80), sv.Color(r=255, g=140, b=0)])  # observed, halted
        out = sv.BoxAnnotator(color=palette, color_lookup=sv.ColorLookup.CLASS, thickness=2).annotate(out, detections)
        out = sv.LabelAnnotator(color=palette, color_lookup=sv.ColorLookup.CLASS, text_scale=0.4,
                                text_padding=2).annotate(out, detections, labels=_labels(states))
    for k, text in enumerate(events):
        out = sv.draw_text(out, text, sv.Point(x=4 + 3 * len(text), y=12 + 16 * k), text_color=sv.Color.WHITE,
                           text_scale=0.4, background_color=sv.Color.BLACK)
    return np.ascontiguousarray(out[:, :, ::-1])


def render_scene(scene: Scene, images: str | os.PathLike, out_dir: str | os.PathLike, video: str | None = None,
                 fps: float | None = None) -> tuple[list[Path], Path | None]:
    """Draw the scene on its frames: ``out_dir/NNNNNN.png`` per frame (numbered as the scene's
    frames) and, with ``video`` (a path ending .mp4 or .gif), the frames as a video at ``fps``
    (default the scene's frame rate, else 10)."""
    from PIL import Image
    files = frame_images(images, scene)
    if video is not None and Path(video).suffix.lower() not in VIDEO_SUFFIXES:
        raise SceneError(f"--video {video}: the video is written as {' or '.join(VIDEO_SUFFIXES)}")
    states = frame_states(scene)
    events: dict[int, list[str]] = {}
    for e in scene.events:
        events.setdefault(e.time, []).append(str(e.event))
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written, frames = [], []
    for k, path in enumerate(files):
        frame = scene.first_frame + k
        with Image.open(path) as img:
            rgb = np.asarray(img.convert("RGB"))
        drawn = draw_frame(rgb, states.get(frame, []), events.get(frame, []))
        target = out / f"{frame:06d}.png"
        Image.fromarray(drawn).save(target)
        written.append(target)
        if video is not None:
            frames.append(drawn)
    if video is None:
        return written, None
    _write_video(Path(video), frames, fps or scene.fps or 10.0)
    return written, Path(video)


def _write_video(path: Path, frames: list[np.ndarray], fps: float) -> None:
    import av
    from fractions import Fraction
    codec, pix_fmt = VIDEO_SUFFIXES[path.suffix.lower()]
    height, width = frames[0].shape[:2]
    with av.open(str(path), "w") as container:
        stream = container.add_stream(codec, rate=Fraction(fps).limit_denominator(1000))
        stream.width, stream.height, stream.pix_fmt = width - width % 2, height - height % 2, pix_fmt
        for rgb in frames:
            frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(rgb[:stream.height, :stream.width]), format="rgb24")
            for packet in stream.encode(frame):
                container.mux(packet)
        for packet in stream.encode():
            container.mux(packet)
