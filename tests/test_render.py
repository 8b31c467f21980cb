"""`refimpl render`: a scene drawn on the user's frames (here frames the test makes: flat grey
640 x 480 images for the bundled TUD-Campus, 71 frames) as one image per frame and a video."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from refimpl.cli import main
from refimpl.scene import load_scene
from refimpl.scene.report import ACTIVE, frame_states

pytest.importorskip("supervision")
av = pytest.importorskip("av")
Image = pytest.importorskip("PIL.Image")

REPO = Path(__file__).resolve().parent.parent
DEMO = REPO / "data" / "demo" / "TUD-Campus" / "det" / "det.txt"
GREY = (90, 90, 90)
OBSERVED, HALTED = (0, 200, 80), (255, 140, 0)  # scene.render's palette


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    root = tmp_path_factory.mktemp("render")
    scene = root / "scene.json"
    assert main(["track", "--dets", str(DEMO), "--out", str(root / "t.txt"), "--scene", str(scene), "--quiet"]) == 0
    frames = root / "img1"
    frames.mkdir()
    for k in range(1, 72):  # seqinfo.ini: 71 frames, 640 x 480
        Image.fromarray(np.full((480, 640, 3), GREY, dtype=np.uint8)).save(frames / f"{k:06d}.png")
    return root, scene, frames


def test_boxes_ids_states_and_events_on_every_frame(made, capsys):
    root, scene_path, frames = made
    out, video = root / "drawn", root / "drawn.mp4"
    assert main(["render", str(scene_path), "--images", str(frames), "--out", str(out), "--video", str(video)]) == 0
    assert capsys.readouterr().out == f"TUD-Campus: 71 frames drawn -> {out}, {video}\n"
    assert sorted(p.name for p in out.iterdir()) == [f"{k:06d}.png" for k in range(1, 72)]
    scene = load_scene(scene_path)
    states = frame_states(scene)
    colours = {ACTIVE: OBSERVED}
    checked = set()
    for frame, boxes in states.items():
        picture = np.asarray(Image.open(out / f"{frame:06d}.png").convert("RGB"))
        for b in boxes:
            x, y, w, h = (int(round(v)) for v in b.box)
            if not (0 < x and x + w < 639 and 20 < y and y + h < 479):
                continue  # a box at the border: its edges may be clipped
            # another box, its label above it (~20 px) on top, or its edge across the two points
            # probed below (the bottom edge and 6 px above it; TUD-Campus frame 71: trk_8's bottom
            # edge runs 4 px above trk_10's)
            others = [o.box for o in boxes if o is not b]
            if any(ox - 3 <= x + w // 2 <= ox + ow + 3 and oy - 25 <= y + h <= oy + oh + 9 for ox, oy, ow, oh in others):
                continue
            # the bottom edge at the middle of the box carries its state's colour (observed green,
            # halted orange); the box's middle stays the frame's own grey (nothing is filled)
            edge = tuple(int(v) for v in picture[y + h, x + w // 2])
            assert edge == colours.get(b.state, HALTED), (frame, b)
            assert tuple(int(v) for v in picture[y + h - 6, x + w // 2]) == GREY, (frame, b)  # inside: not filled
            checked.add(b.state == ACTIVE)
    assert checked == {True, False}  # both an observed and a halted box were drawn
    # a frame with events has their text on black top left; a frame without none
    with_events = {e.time for e in scene.events}
    first = min(with_events)
    corner = np.asarray(Image.open(out / f"{first:06d}.png").convert("RGB"))[4:20, 4:200]
    assert (corner == 0).all(axis=2).any()
    calm = min(f for f in range(1, 72) if f not in with_events and all(b.box[1] >= 40 for b in states[f]))
    corner = np.asarray(Image.open(out / f"{calm:06d}.png").convert("RGB"))[4:20, 4:200]
    assert not (corner == 0).all(axis=2).any()  # no box or label reaches up there: no text, no black
    # the video holds every frame
    with av.open(str(video)) as container:
        assert sum(1 for _ in container.decode(video=0)) == 71


@pytest.mark.parametrize("case, message", [
    ("few", "--images {frames5}: 5 image(s)"),
    ("full", "--out {full}: give a new or empty folder"),
    ("video", "--video {root}/x.avi: the video is written as .mp4 or .gif"),
])
def test_mistakes_are_one_line(made, capsys, case, message):
    root, scene_path, frames = made
    frames5 = root / "five"
    if not frames5.exists():
        frames5.mkdir()
        for k in range(5):
            (frames5 / f"{k:06d}.png").write_bytes((frames / f"{k + 1:06d}.png").read_bytes())
    full = root / "full"
    full.mkdir(exist_ok=True)
    (full / "x.txt").write_text("mine")
    argv = {"few": ["--images", str(frames5), "--out", str(root / "o1")],
            "full": ["--images", str(frames), "--out", str(full)],
            "video": ["--images", str(frames), "--out", str(root / "o2"), "--video", str(root / "x.avi")]}[case]
    assert main(["render", str(scene_path), *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and message.format(frames5=frames5, full=full, root=root) in err
