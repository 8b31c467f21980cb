"""`refimpl report`: the box states, timelines and explanations it shows, the self-contained page,
its one-line errors, and the page rendered by a real headless Chromium.

The states are checked on the hand-made BUS scene of test_scene.py, whose numbers are derived
there: trk_13 hides behind the bus trk_12 at 235 and unhides at 268 (halted 235..267), trk_5 is
missed at 210 and recovered at 212 (halted 210, 211) and leaves at 250, trk_7 is noise at 207.
The browser test takes KITTI Car 0011 tracked as the issue says (conftest.py), writes its report, opens it
in /usr/bin/chromium (skipped without it): the page's script must have drawn every box of the
chosen frame, no console error, and a screenshot that shows the figures in their colours.
"""

from __future__ import annotations

import base64
import json
import re
import struct
import subprocess
import zlib
from pathlib import Path

import pytest

from refimpl import cli
from refimpl.scene.report import ACTIVE, HIDDEN, MISSING, build_report, default_frame, frame_states
from refimpl.scene.report_html import STATE_COLOURS, frame_data, render_html
from refimpl.scene import load_scene, save_scene

from test_scene import bus_scene

REPO = Path(__file__).resolve().parent.parent
CHROMIUM = Path("/usr/bin/chromium")


def _states(scene, frame) -> dict[str, tuple[str, str | None]]:
    return {b.track: (b.state, b.hidden_by) for b in frame_states(scene)[frame]}


# ---------------------------------------------------------------------------------------
# what the report says


def test_box_states_follow_the_halts_and_their_explaining_events():
    s = bus_scene()
    # 234: the car is still observed; 235..267 halted behind the bus; 268 observed again (resumed)
    assert _states(s, 234)["trk_13"] == (ACTIVE, None)
    assert _states(s, 235)["trk_13"] == (HIDDEN, "trk_12")
    assert _states(s, 267)["trk_13"] == (HIDDEN, "trk_12")
    assert _states(s, 268)["trk_13"] == (ACTIVE, None)
    # trk_5 missed by the detector at 210 and 211, recovered at 212
    assert _states(s, 210)["trk_5"] == (MISSING, None) and _states(s, 211)["trk_5"] == (MISSING, None)
    assert _states(s, 212)["trk_5"] == (ACTIVE, None)
    # 245: the bus, the hidden car (its predicted box x = 100 + 5 (245 - 234) = 155) and trk_5
    at = frame_states(s)[245]
    assert [b.track for b in at] == ["trk_5", "trk_12", "trk_13"]
    assert at[2].box == (155.0, 120.0, 40.0, 60.0)
    # nothing before 200 or after the car's and the bus's last frame 280 is left out: 81 frames
    assert sorted(frame_states(s)) == list(range(200, 281))


def test_default_frame_is_the_first_with_the_most_hidden_tracks():
    s = bus_scene()
    # only trk_13 is ever hidden, at 235..267: one hidden box each, the earliest is 235
    assert default_frame(s, frame_states(s)) == 235
    assert build_report(s).frame == 235 and build_report(s, 245).frame == 245


def test_timelines_and_explanations_name_their_tracks():
    r = build_report(bus_scene())
    by = {t.track: t for t in r.tracks}
    t5 = by["trk_5"]
    assert [(e.time, e.name) for e in t5.events] == [(200, "enters_fov"), (210, "missing_detections"),
                                                     (212, "recover"), (250, "leaves_fov")]
    assert t5.observed_runs == ((200, 209), (212, 250)) and t5.halted_runs == ((210, 211, True),)
    assert t5.ended_by == "leaves_fov" and by["trk_7"].ended_by == "noise" and by["trk_12"].ended_by is None
    assert not by["trk_7"].drawn  # 2 observed frames: below the space-time picture's cut of 3, as in `plot`
    hiding = next(x for x in r.explanations if "went out of sight behind" in x.sentence)
    assert hiding.tracks == ("trk_13", "trk_12") and hiding.frame == 235
    # by first frame, then id in number order: trk_5 and trk_12 start at 200, trk_7 at 205, trk_13 at 220
    assert [t.track for t in r.tracks] == ["trk_5", "trk_12", "trk_7", "trk_13"]


def test_the_page_is_self_contained_and_carries_every_frame():
    page = render_html(build_report(bus_scene(), 245))
    # no URL, no external file: no src / href / url(...) / @import at all, no http(s)
    assert not re.search(r"https?:|\bsrc=|\bhref=|url\(|@import", page)
    data = json.loads(re.search(r'<script type="application/json" id="report-data">(.*?)</script>', page).group(1))
    assert data["frame"] == 245 and len(data["frames"]) == 81
    tracks = [t[0] for t in data["tracks"]]
    rows = data["frames"][245 - 200]
    # trk_13 at 245: its predicted box, state hidden, behind trk_12
    car = next(r for r in rows if tracks[r[0]] == "trk_13")
    assert car[1:5] == [155.0, 120.0, 40.0, 60.0] and data["states"][car[5]] == HIDDEN and tracks[car[6]] == "trk_12"
    assert data["stateColours"][car[5]] == STATE_COLOURS[HIDDEN]
    assert "hidden_by(trk_13,trk_12)" in data["relations"][245 - 200]
    # the space-time picture: observed runs of the three drawn tracks (trk_12 1, trk_5 2, trk_13 2) and
    # the halted runs (trk_5 1, trk_13 1) are 7 bars
    assert page.count('<rect class="bar"') == 7
    assert frame_data(build_report(bus_scene(), 245)) == data


def test_report_command_writes_the_page_and_refuses_mistakes_in_one_line(tmp_path, capsys):
    scene = tmp_path / "bus.json"
    save_scene(scene, bus_scene())
    out = tmp_path / "bus.html"
    assert cli.main(["report", str(scene), "--out", str(out), "--frame", "245"]) == 0
    assert capsys.readouterr().out == f"BUS: 4 tracks, 10 events, frame 245 (3 boxes) -> {out}\n"
    first = out.read_bytes()
    assert first.startswith(b"<!DOCTYPE html>") and b"data-report=\"loading\"" in first
    assert cli.main(["report", str(scene), "--out", str(out), "--frame", "245"]) == 0
    assert out.read_bytes() == first  # deterministic
    other = str(tmp_path / "x.html")
    for argv, message in ((["--out", other, "--frame", "281"], "frame 281 is outside the scene (200-280)"),
                          (["--out", str(scene)], "refusing to overwrite an input"),
                          (["--out", str(tmp_path)], "is a directory")):
        assert cli.main(["report", str(scene), *argv]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and err.startswith("refimpl report: error: ") and message in err, err
    assert not (tmp_path / "x.html").exists()
    assert cli.main(["report", str(tmp_path / "missing.json"), "--out", str(tmp_path / "x.html")]) == 2
    assert capsys.readouterr().err.count("\n") == 1 and not (tmp_path / "x.html").exists()
    # standard output: the page alone on stdout, the summary on stderr
    assert cli.main(["report", str(scene), "--out", "-", "--frame", "245"]) == 0
    captured = capsys.readouterr()
    assert captured.out.encode() == first and captured.err.startswith("BUS: 4 tracks")


# ---------------------------------------------------------------------------------------
# in a real browser: headless Chromium (a link's frame and track; KITTI Car 0011)


def _headless(url: str, profile: Path, *extra: str) -> subprocess.CompletedProcess:
    """/usr/bin/chromium --headless on url: the DOM after the scripts ran on stdout, console lines on stderr."""
    run = subprocess.run(
        [str(CHROMIUM), "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--enable-logging=stderr", "--v=0", f"--user-data-dir={profile}", "--window-size=1200,900", *extra,
         "--dump-dom", url], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr[-3000:]
    assert not [line for line in run.stderr.splitlines() if ":CONSOLE" in line]  # the page logs nothing
    return run


@pytest.mark.skipif(not CHROMIUM.exists(), reason="no /usr/bin/chromium (apt-get install chromium)")
def test_a_link_opens_the_page_at_its_frame_and_track(tmp_path):
    page = tmp_path / "bus.html"
    page.write_text(render_html(build_report(bus_scene())), encoding="utf-8")
    dom = _headless(page.resolve().as_uri() + "#frame=210&track=5", tmp_path / "profile").stdout
    assert 'data-report="rendered"' in dom
    # frame 210: the bus and trk_5, which the detector missed (210, 211); only trk_5's rows stay shown
    assert 'id="frame-number">210 (2 boxes)<' in dom
    frame_row = r'<tr data-tracks="([^"]*)"( class="hide")?><td>\d+</td><td>\w+</td><td class="state"'
    rows = dict(re.findall(frame_row, dom))
    assert rows == {"trk_5": "", "trk_12": ' class="hide"'}
    assert "halted: missed by the detector" in dom
    assert len(re.findall(r'<g class="box missing halted-kind" data-track="trk_5">', dom)) == 1


@pytest.mark.skipif(not CHROMIUM.exists(), reason="no /usr/bin/chromium (apt-get install chromium)")
def test_kitti_car_0011_report_renders_in_headless_chromium(kitti_car_0011, tmp_path, capsys):
    scene_file, page = kitti_car_0011["scene"], tmp_path / "report.html"
    assert cli.main(["report", str(scene_file), "--out", str(page)]) == 0
    capsys.readouterr()
    scene = load_scene(scene_file)
    report = build_report(scene)
    # the first hiding of the event log: its track is shown hidden behind its occluder at that frame
    hide = next(e for e in scene.events if e.event.name == "hides_behind")
    t1, t2 = (str(a) for a in hide.event.args)
    assert any(b.track == t1 and b.state == HIDDEN and b.hidden_by == t2 for b in report.states_at(hide.time))

    # one headless run: the DOM after the page's script ran (stdout), a screenshot, console messages (stderr)
    shot = tmp_path / "shot.png"
    run = _headless(page.resolve().as_uri(), tmp_path / "profile", f"--screenshot={shot}")

    # the script ran to its end and drew every box of the chosen frame
    assert 'data-report="rendered"' in run.stdout, re.findall(r'data-report="[^"]*"', run.stdout)
    boxes = len(report.states_at(report.frame))
    assert boxes > 0 and len(re.findall(r'<g class="box (active|hidden|missing|halted)', run.stdout)) == boxes
    assert f"rendered: frame {report.frame} with {boxes} boxes" in run.stdout

    # the screenshot is not blank: many colours, among them the active (blue) and hidden (red) boxes'
    imread = pytest.importorskip("matplotlib.image").imread
    image = imread(str(shot))
    assert image.shape[:2] == (900, 1200)
    pixels = {tuple(p) for p in (image[:, :, :3].reshape(-1, 3) * 255).round().astype(int).tolist()}
    assert len(pixels) > 200
    for colour in (STATE_COLOURS[ACTIVE], STATE_COLOURS[HIDDEN]):
        rgb = tuple(int(colour[i:i + 2], 16) for i in (1, 3, 5))
        assert rgb in pixels, colour


# ---------------------------------------------------------------------------------------
# the legend of the relation codes


def _emitted_codes() -> set[str]:
    """Every word frame_relations (what the relations list prints for a pair) says on a grid of box pairs."""
    from refimpl.scene.queries import frame_relations
    seen: set[str] = set()
    sizes = (5, 10, 20, 40)
    for aw in sizes:
        for ah in sizes:
            a = (20, 20, aw, ah)
            for x in range(0, 70, 5):
                for y in range(0, 70, 5):
                    for bw in sizes:
                        for bh in sizes:
                            seen.update(frame_relations(a, (x, y, bw, bh)))
    return seen


def test_every_relation_code_has_a_legend_entry_and_every_entry_is_said():
    from refimpl.knowledge.relations import RCC8_CODE, RELATION_CODES, TOPOLOGY_RELATIONS, orientation
    codes = [r.code for r in RELATION_CODES]
    assert len(codes) == len(set(codes))
    # every answer of topology() and of orientation() has a code (RCC-8: 8 of them, 4 orientation words)
    assert sorted(RCC8_CODE) == sorted(TOPOLOGY_RELATIONS) and len(RCC8_CODE) == 8
    assert orientation((0, 0, 1, 1), (5, 5, 1, 1)) <= set(codes) and orientation((5, 5, 1, 1), (0, 0, 1, 1)) <= set(codes)
    # both ways on 16 x 16 x 14 x 14 x 16 box pairs: what the listing says is in the table, and no row is dead
    # (eq at x = y = 20 with equal sizes, ntpp/ntppi for a 5 box inside a 20 one, far for 5 boxes 40 px apart, ...)
    assert _emitted_codes() == set(codes)
    # the page's legend: one <dt data-code> per row of the table, in its order, with its meaning
    page = render_html(build_report(bus_scene(), 245))
    assert re.findall(r'<dt data-code="([^"]+)">', page) == codes
    assert "<dt>clipped(T)</dt>" in page and "<dt>hidden_by(T1,T2)</dt>" in page
    # overlapping_top's threshold is the model's hide_overlap, 10 (model/constants.lp)
    assert "more than hide_overlap % (= 10 %) of A" in page
    # the bus frame's line "12 13 ntppi, in_front_of, near" (test_plots.py): each code explained
    assert all(f'<dt data-code="{c}">' in page for c in ("ntppi", "in_front_of", "near"))


# ---------------------------------------------------------------------------------------
# labels without overlap in a crowded frame (headless Chromium)


def crowded_scene():
    """20 cars in a jam at frame 0 on a KITTI-sized image (1242 x 375): boxes 60 x 40 px at y = 150, 3 px
    apart in x (x = 300, 303, ..., 357).  The page's labels are bold 15 px (user units): about 10.4 units
    wide for one digit, 20.8 for two, kept 1 apart.  A label starts at its box's x, so one row of labels
    spans at most 300 .. 357 + 21 = 378, 78 units, while the 20 labels need 9 x 11.4 + 11 x 21.8 = 343:
    at least 5 rows.  The four places next to a box (above, below, inside top, inside bottom) are one
    row each, as every box has the same y: some labels must be stacked."""
    from refimpl.scene import SceneTrack, make_scene
    tracks = [SceneTrack(f"trk_{i + 1}", "Car", ((0, (300.0 + 3 * i, 150.0, 60.0, 40.0)),), (), None)
              for i in range(20)]
    return make_scene("JAM", tracks, [], 0, 0, (1242, 375), 10.0)


def _rects(dom: str) -> list[tuple[float, float, float, float]]:
    return [tuple(map(float, r.split(","))) for r in re.findall(r'<text class="label"[^>]* data-rect="([^"]+)"', dom)]


@pytest.mark.skipif(not CHROMIUM.exists(), reason="no /usr/bin/chromium (apt-get install chromium)")
def test_box_labels_do_not_overlap_in_a_crowded_frame(tmp_path):
    page = tmp_path / "jam.html"
    page.write_text(render_html(build_report(crowded_scene())), encoding="utf-8")
    dom = _headless(page.resolve().as_uri(), tmp_path / "profile").stdout
    assert 'data-report="rendered"' in dom and "rendered: frame 0 with 20 boxes" in dom
    rects = _rects(dom)
    assert len(rects) == 20 and all(w > 5 and h > 5 for _, _, w, h in rects)  # every label drawn, with a size
    for i, (x1, y1, w1, h1) in enumerate(rects):
        for x2, y2, w2, h2 in rects[i + 1:]:
            overlap_x, overlap_y = min(x1 + w1, x2 + w2) - max(x1, x2), min(y1 + h1, y2 + h2) - max(y1, y2)
            assert overlap_x <= 0 or overlap_y <= 0, ((x1, y1, w1, h1), (x2, y2, w2, h2))
    # the crowd forced stacking (crowded_scene): at least 5 rows, more than the 4 places next to a box
    assert len({round(y) for _, y, _, _ in rects}) > 4
    # the picture's frame: every label lies inside the drawn SVG (stacked rows under the image included)
    svg = re.search(r'<div id="frame-view"><svg viewBox="0 0 1242 ([\d.]+)"', dom)
    assert svg is not None
    # deterministic: a second run places every label at the same place
    assert _rects(_headless(page.resolve().as_uri(), tmp_path / "profile2").stdout) == rects


# ---------------------------------------------------------------------------------------
# the frame images under the boxes (--images)


def _png(path: Path, width: int, height: int, rgb: tuple[int, int, int]) -> None:
    """A solid-colour 8-bit RGB PNG, written with the standard library (no image library needed)."""
    def chunk(kind: bytes, body: bytes) -> bytes:
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))
    rows = b"".join(b"\0" + bytes(rgb) * width for _ in range(height))
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0))
                     + chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b""))


def frame_colour(frame: int) -> tuple[int, int, int]:
    """Each frame image's own colour: frame 245 is (45, 210, 140), a colour nothing else on the page has."""
    return (frame - 200, 255 - (frame - 200), 140)


@pytest.fixture
def bus_frames(tmp_path):
    """The BUS scene (600 x 240 px, frames 200..280) and a folder of its 81 frames, 000200.png .. 000280.png."""
    scene, folder = tmp_path / "bus.json", tmp_path / "img"
    save_scene(scene, bus_scene())
    folder.mkdir()
    for f in range(200, 281):
        _png(folder / f"{f:06d}.png", 600, 240, frame_colour(f))
    return scene, folder


def _images(page: str) -> dict[int, list]:
    block = re.search(r'<script type="application/json" id="report-images">(.*?)</script>', page)
    return {int(k): v for k, v in json.loads(block.group(1)).items()} if block else {}


def test_report_embeds_the_frame_images_as_they_are(bus_frames, tmp_path, capsys):
    scene, folder = bus_frames
    out = tmp_path / "bus.html"
    assert cli.main(["report", str(scene), "--out", str(out), "--frame", "245", "--images", str(folder)]) == 0
    summary = capsys.readouterr().out
    images = _images(out.read_text())
    # by default the frame shown, 245, and the 25 either side: 220..270, 51 files, each byte for byte the
    # file of its frame (render's rule: name order from the scene's first frame, 200)
    assert sorted(images) == list(range(220, 271))
    for f, (uri, width, height) in images.items():
        assert uri.startswith("data:image/png;base64,") and (width, height) == (600, 240)
        assert base64.b64decode(uri.split(",", 1)[1]) == (folder / f"{f:06d}.png").read_bytes()
    mb = sum(len(v[0]) for v in images.values()) / 1e6
    assert summary == (f"BUS: 4 tracks, 10 events, frame 245 (3 boxes); the images of frames 220-270 embedded "
                       f"(51 files, {mb:.1f} MB) -> {out}\n")
    # a range, and all of them
    for frames, expected in (("200:210", range(200, 211)), ("all", range(200, 281)), (":203", range(200, 204))):
        assert cli.main(["report", str(scene), "--out", str(out), "--images", str(folder), "--image-frames", frames]) == 0
        capsys.readouterr()
        assert sorted(_images(out.read_text())) == list(expected)
    # without --images: no image block, the page of before
    assert cli.main(["report", str(scene), "--out", str(out), "--frame", "245"]) == 0
    assert _images(out.read_text()) == {} and out.read_text() == render_html(build_report(bus_scene(), 245))


def test_image_header_reads_png_and_jpeg_sizes(tmp_path):
    from refimpl.scene.report_images import image_header
    _png(tmp_path / "a.png", 7, 3, (1, 2, 3))
    assert image_header((tmp_path / "a.png").read_bytes()) == ("image/png", 7, 3)
    Image = pytest.importorskip("PIL.Image")
    Image.new("RGB", (33, 17), (200, 10, 10)).save(tmp_path / "b.jpg", quality=90)
    assert image_header((tmp_path / "b.jpg").read_bytes()) == ("image/jpeg", 33, 17)
    assert image_header(b"GIF89a....") is None and image_header(b"\xff\xd8\xff\xe0") is None  # cut short


def test_report_images_mistakes_are_one_line(bus_frames, tmp_path, capsys):
    scene, folder = bus_frames
    out = tmp_path / "x.html"
    few = tmp_path / "few"
    few.mkdir()
    for f in range(200, 210):
        _png(few / f"{f:06d}.png", 600, 240, (0, 0, 0))
    bad = tmp_path / "bad"
    bad.mkdir()
    for f in range(200, 281):
        (bad / f"{f:06d}.png").write_bytes((folder / f"{f:06d}.png").read_bytes())
    (bad / "000230.png").write_bytes(b"not an image")
    small = tmp_path / "small"
    small.mkdir()
    for f in range(200, 281):
        _png(small / f"{f:06d}.png", 300, 120, (0, 0, 0))
    cases = ((["--images", str(tmp_path / "none")], "not a folder of frame images"),
             (["--images", str(few)], "10 image(s)"),
             (["--images", str(bad)], "000230.png (frame 230) is not a readable PNG or JPEG image"),
             (["--images", str(small)], "is 300 x 120 px, but scene BUS is 600 x 240 px"),
             (["--images", str(folder), "--image-frames", "5:1"], "--image-frames must be all or FROM:TO"),
             (["--images", str(folder), "--image-frames", "190:210"], "the scene's frames are 200..280"),
             (["--image-frames", "200:210"], "--image-frames needs --images DIR"))
    for argv, message in cases:
        assert cli.main(["report", str(scene), "--out", str(out), *argv]) == 2, argv
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and err.startswith("refimpl report: error: ") and message in err, err
        assert not out.exists()


@pytest.mark.skipif(not CHROMIUM.exists(), reason="no /usr/bin/chromium (apt-get install chromium)")
def test_the_frame_image_is_drawn_under_the_boxes_in_headless_chromium(bus_frames, tmp_path, capsys):
    scene, folder = bus_frames
    page = tmp_path / "bus.html"
    assert cli.main(["report", str(scene), "--out", str(page), "--frame", "245", "--images", str(folder)]) == 0
    capsys.readouterr()
    shot = tmp_path / "shot.png"
    run = _headless(page.resolve().as_uri(), tmp_path / "profile", f"--screenshot={shot}")
    assert 'data-report="rendered"' in run.stdout
    assert 'id="frame-number">245 (3 boxes, on its image)<' in run.stdout
    # the image element sits under the boxes: right after the picture's background, before any box
    assert re.search(r'<rect class="image"[^>]*></rect><image class="frame-image" x="0" y="0" width="600" '
                     r'height="240" preserveAspectRatio="none" href="data:image/png;base64,', run.stdout)
    assert run.stdout.index('class="frame-image"') < run.stdout.index('<g class="box')
    # the screenshot shows frame 245's own colour (frame_colour) and not a neighbour's
    imread = pytest.importorskip("matplotlib.image").imread
    pixels = {tuple(p) for p in (imread(str(shot))[:, :, :3].reshape(-1, 3) * 255).round().astype(int).tolist()}
    assert frame_colour(245) in pixels and frame_colour(244) not in pixels and frame_colour(246) not in pixels
    # frame 210 lies outside the images carried by default (220..270): the plain picture, said so
    dom = _headless(page.resolve().as_uri() + "#frame=210", tmp_path / "profile2").stdout
    assert 'id="frame-number">210 (2 boxes, no image embedded for this frame)<' in dom
    assert 'class="frame-image"' not in dom
