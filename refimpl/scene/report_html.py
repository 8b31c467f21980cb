"""The scene report as one self-contained HTML page (``refimpl report``): no server, no network.

Everything is inline: the CSS, the script, the space-time picture (SVG drawn here, in the colours
and markers of ``refimpl plot``) and the data the script draws the chosen frame from (a JSON block
with the box states of every frame, ``refimpl.scene.report``).  The page references no file and no URL.

Sections: the chosen frame (its boxes drawn by state -- active solid, hidden / missing / halted
dashed -- with a slider to move through the frames, the table of its boxes and the relations
that hold), the space-time picture (one row per track; a click picks the frame), the events per
track (a click on an event picks its frame) and the explanations.  The box labels (track number, the occluder of
a hidden box) are placed by the script so that no two overlap: above the box, below it, inside, then
stacked (``placeLabels``); each label's rectangle on the screen is left in its ``data-rect``.  A filter field keeps one
track's rows; ``report.html#frame=274&track=129`` opens the page at that frame with that filter.  When the script has drawn the page it sets ``data-report="rendered"`` on the
``<html>`` element and fills ``#report-status`` (a script error sets ``data-report="error: ..."``):
what a headless browser test reads.  With the frame images (``--images``,
refimpl.scene.report_images) a second JSON block holds them as data URIs; the script puts the shown
frame's image under its boxes.  :func:`write_report` is the command: load the scene, build
its report (refimpl.scene.report), write the page.
"""

from __future__ import annotations

import dataclasses
import html
import json

from ..core.constants import default_constants
from ..core.display import visible
from ..knowledge.event_table import explaining
from ..knowledge.relations import RELATION_CODES
from .plots import ENDED_COLOUR, EVENT_STYLE, OBSERVED_COLOUR, PAIR_EVENTS, RESUMED_COLOUR
from ..io.outputs import check_outputs, write_atomic
from .report import ACTIVE, HALTED, MISSING, Report, STATES, TrackTimeline, build_report
from .report_images import FrameImage, image_frames, load_frame_images
from . import SceneError, load_scene

STATE_COLOURS = {ACTIVE: OBSERVED_COLOUR, **{e.halt_kind: e.colour for e in explaining("halt")},
                 HALTED: ENDED_COLOUR}
STATE_TEXT = {ACTIVE: "active (observed)",
              **{e.halt_kind: f"halted: {e.halt_kind}" + (" behind" if e.occluder is not None else "")
                 for e in explaining("halt")},
              MISSING: "halted: missed by the detector", HALTED: "halted"}
"""Every state's legend: a halt kind's from the event table ('halted: hidden behind'), the
detector's miss in words of its own."""

LABEL_W, PLOT_W, ROW_H, AXIS_H = 110.0, 1060.0, 14.0, 22.0
"""Space-time picture geometry (SVG user units): label column, plot width, row height, axis band."""


def _e(text) -> str:
    """Text of the page: its control characters written out (refimpl.core.display: a scene file's
    ``\x1b`` shows as such, on a terminal too with ``--out -``), then HTML-escaped."""
    return html.escape(visible(str(text)), quote=True)


def _marker(code: str, x: float, y: float, colour: str) -> str:
    """An SVG shape for a matplotlib marker code of the event table (v ^ > < x + s D, else a circle)."""
    r = 4.0
    points = {"v": [(-r, -r), (r, -r), (0, r)], "^": [(-r, r), (r, r), (0, -r)], ">": [(-r, -r), (-r, r), (r, 0)],
              "<": [(r, -r), (r, r), (-r, 0)], "D": [(0, -r), (r, 0), (0, r), (-r, 0)],
              "s": [(-r, -r), (r, -r), (r, r), (-r, r)]}
    if code in points:
        pts = " ".join(f"{x + dx:.1f},{y + dy:.1f}" for dx, dy in points[code])
        return f'<polygon points="{pts}" fill="{colour}"/>'
    if code in ("x", "+"):
        d = (f"M{x - r:.1f},{y - r:.1f}L{x + r:.1f},{y + r:.1f}M{x - r:.1f},{y + r:.1f}L{x + r:.1f},{y - r:.1f}"
             if code == "x" else f"M{x - r:.1f},{y:.1f}L{x + r:.1f},{y:.1f}M{x:.1f},{y - r:.1f}L{x:.1f},{y + r:.1f}")
        return f'<path d="{d}" stroke="{colour}" stroke-width="1.8"/>'
    return f'<circle cx="{x:.1f}" cy="{y:.1f}" r="{r}" fill="{colour}"/>'


def _tick_step(span: int) -> int:
    for step in (1, 2, 5, 10, 20, 25, 50, 100, 200, 250, 500, 1000, 2000, 5000, 10000):
        if span / step <= 16:
            return step
    return 10 ** len(str(span))


def spacetime_svg(report: Report) -> str:
    """The space-time picture: one row per drawn track (observed blue, halted then resumed orange,
    halted then ended grey), its events as markers, pair events joined to the other track's row."""
    rows = [t for t in report.tracks if t.drawn]
    if not rows:
        return '<p class="empty">No track was observed in 3 or more frames: nothing to draw.</p>'
    lo, hi = report.first_frame, report.last_frame
    sx = PLOT_W / (hi - lo + 1)
    height = AXIS_H * 2 + ROW_H * len(rows)
    index = {t.track: i for i, t in enumerate(rows)}

    def x(f: float) -> float:
        return LABEL_W + (f - lo) * sx

    def y(i: int) -> float:
        return AXIS_H + (i + 0.5) * ROW_H

    out = [f'<svg id="spacetime-svg" viewBox="0 0 {LABEL_W + PLOT_W + 10:.0f} {height:.0f}" role="img" '
           f'aria-label="space-time picture of {len(rows)} tracks" data-first="{lo}" data-left="{LABEL_W:g}" '
           f'data-sx="{sx!r}">']
    step = _tick_step(hi - lo + 1)
    for f in range((lo // step) * step, hi + 1, step):
        if f < lo:
            continue
        out.append(f'<line class="grid" x1="{x(f + 0.5):.1f}" y1="{AXIS_H - 4:.0f}" x2="{x(f + 0.5):.1f}" '
                   f'y2="{height - AXIS_H + 4:.0f}"/>')
        for ty in (AXIS_H - 7, height - 6):
            out.append(f'<text class="tick" x="{x(f + 0.5):.1f}" y="{ty:.0f}">{f}</text>')
    for i, t in enumerate(rows):
        top = y(i) - ROW_H * 0.32
        out.append(f'<g class="row" data-track="{_e(t.track)}"><text class="label" x="{LABEL_W - 6:g}" '
                   f'y="{y(i) + 4:.1f}">{_e(t.number)} {_e(t.type)}</text>')
        for a, b in t.observed_runs:
            out.append(f'<rect class="bar" x="{x(a):.2f}" y="{top:.1f}" width="{(b - a + 1) * sx:.2f}" '
                       f'height="{ROW_H * 0.64:.1f}" fill="{OBSERVED_COLOUR}"/>')
        for a, b, resumed in t.halted_runs:
            colour = RESUMED_COLOUR if resumed else ENDED_COLOUR
            out.append(f'<rect class="bar" x="{x(a):.2f}" y="{top:.1f}" width="{(b - a + 1) * sx:.2f}" '
                       f'height="{ROW_H * 0.64:.1f}" fill="{colour}"/>')
        out.append("</g>")
    for i, t in enumerate(rows):
        for ev in t.events:
            style = EVENT_STYLE.get(ev.name)
            if style is None or not lo <= ev.time <= hi:
                continue
            marker, colour, _ = style
            cx = x(ev.time + 0.5)
            what = f"{ev.name}({t.track}{',' + ev.other if ev.other else ''}) at frame {ev.time}"
            out.append(f'<g class="event" data-track="{_e(t.track)}" data-frame="{ev.time}"><title>{_e(what)}</title>')
            if ev.name in PAIR_EVENTS and ev.other in index:
                out.append(f'<line class="pair" x1="{cx:.1f}" y1="{y(i):.1f}" x2="{cx:.1f}" '
                           f'y2="{y(index[ev.other]):.1f}" stroke="{colour}"/>')
            out.append(_marker(marker, cx, y(i), colour) + "</g>")
    cursor = x(report.frame + 0.5)
    out.append(f'<line id="cursor" x1="{cursor:.1f}" y1="{AXIS_H - 4:.0f}" x2="{cursor:.1f}" '
               f'y2="{height - AXIS_H + 4:.0f}"/></svg>')
    return "\n".join(out)


def _legend() -> str:
    items = [(OBSERVED_COLOUR, "observed"), (RESUMED_COLOUR, "halted, then resumed (hidden / missing)"),
             (ENDED_COLOUR, "halted, then ended (or still halted)")]
    parts = [f'<span class="key"><i style="background:{c}"></i>{_e(t)}</span>' for c, t in items]
    parts += [f'<span class="key"><svg class="mark" viewBox="-6 -6 12 12">{_marker(m, 0, 0, c)}</svg>{_e(name)}</span>'
              for name, (m, c, _) in EVENT_STYLE.items()]
    return '<p class="legend">' + " ".join(parts) + "</p>"


FLUENT_TEXT = (("clipped(T)", "T was missed by the detector: from the frame after its missing_detections to "
                               "the frame it is resumed"),
               ("hidden_by(T1,T2)", "T1 is hidden behind T2: from the frame after its hides_behind to the frame "
                                    "of its unhides_from_behind"))
"""The fluents the relations list names (refimpl.scene.plots.frame_relation_lines)."""


def relation_legend() -> str:
    """What every line of the relations list means: the fluents, then every code of the relation
    code table (refimpl.knowledge.relations.RELATION_CODES), in its order."""
    hide = default_constants()["hide_overlap"]
    rows = [f'<dt>{_e(name)}</dt><dd>{_e(text)}</dd>' for name, text in FLUENT_TEXT]
    rows.append('<dt class="head">A B codes</dt><dd class="head">a pair of tracks whose boxes touch or are near: '
                'the relations of track A to track B</dd>')
    for r in RELATION_CODES:
        text = r.meaning.replace("hide_overlap %", f"hide_overlap % (= {hide} %)")
        rows.append(f'<dt data-code="{_e(r.code)}">{_e(r.code)}</dt><dd>{_e(text)}</dd>')
    return '<dl class="codes" id="relation-codes">' + "".join(rows) + "</dl>"


def _event_chip(t: TrackTimeline, ev, numbers: dict[str, object]) -> str:
    colour = EVENT_STYLE[ev.name][1] if ev.name in EVENT_STYLE else "#444444"
    other = f" {numbers.get(ev.other, ev.other)}" if ev.other else ""
    title = f"{ev.name}({t.track}{',' + ev.other if ev.other else ''}) at frame {ev.time}"
    return (f'<button type="button" class="ev" style="--c:{colour}" data-frame="{ev.time}" title="{_e(title)}">'
            f'{ev.time} {_e(ev.name)}{_e(other)}</button>')


def events_table(report: Report) -> str:
    numbers = {t.track: t.number for t in report.tracks}
    rows = []
    for t in report.tracks:
        if t.ended_by:
            end = f"{t.ended_by} at {t.last_frame}"
        else:
            end = "alive at the end" if t.last_frame == report.last_frame else f"ended at {t.last_frame}"
        chips = " ".join(_event_chip(t, ev, numbers) for ev in t.events) or '<span class="none">no events</span>'
        rows.append(f'<tr data-tracks="{_e(t.track)}"><td>{_e(t.number)}</td><td>{_e(t.type)}</td>'
                    f'<td>{t.first_frame}-{t.last_frame}</td><td>{t.observed} / {t.halted}</td><td>{_e(end)}</td>'
                    f'<td class="chips">{chips}</td></tr>')
    return ('<table class="events"><thead><tr><th>track</th><th>type</th><th>frames</th><th>observed / halted</th>'
            '<th>end</th><th>events (click: show that frame)</th></tr></thead><tbody>' + "\n".join(rows)
            + "</tbody></table>")


def explanations_list(report: Report) -> str:
    if not report.explanations:
        return '<p class="empty">The event log is empty.</p>'
    items = [f'<li data-tracks="{_e(" ".join(x.tracks))}" data-frame="{x.frame}">{_e(x.sentence)}</li>'
             for x in report.explanations]
    return '<ol class="explanations">' + "\n".join(items) + "</ol>"


def frame_data(report: Report) -> dict:
    """What the script draws frames from: tracks, and per frame [track, x, y, w, h, state, hider] rows."""
    index = {t.track: i for i, t in enumerate(report.tracks)}
    frames = [[[index[b.track], *b.box, STATES.index(b.state), index.get(b.hidden_by, -1) if b.hidden_by else -1]
               for b in states] for states in report.frames]
    # the scene's strings as the page's text shows them (_e), so that the script's track ids are the
    # data-track attributes it compares them with
    return {"name": visible(report.name), "first": report.first_frame, "last": report.last_frame,
            "frame": report.frame, "canvas": list(report.canvas),
            "ego": list(report.ego_region) if report.ego_region else None,
            "tracks": [[visible(t.track), visible(str(t.number)) if isinstance(t.number, str) else t.number,
                        visible(t.type)] for t in report.tracks], "states": list(STATES),
            "stateText": [STATE_TEXT[s] for s in STATES], "stateColours": [STATE_COLOURS[s] for s in STATES],
            "frames": frames, "relations": [[visible(line) for line in r] for r in report.relations],
            "explanations": len(report.explanations)}


def _json_script(data: dict, ident: str = "report-data") -> str:
    text = json.dumps(data, separators=(",", ":"), ensure_ascii=True).replace("<", "\\u003c")
    return f'<script type="application/json" id="{ident}">{text}</script>'


def _images_script(images: tuple[FrameImage, ...]) -> str:
    """The frame images (refimpl.scene.report_images) as frame -> [data URI, width, height]; none: nothing."""
    if not images:
        return ""
    return _json_script({str(i.frame): [i.data_uri(), i.width, i.height] for i in images}, "report-images")


def render_html(report: Report, images: tuple[FrameImage, ...] = ()) -> str:
    """The whole page (module doc), with the frame images under the boxes when given."""
    if images and not report.image_size:  # no size in the scene: the picture holds the boxes and the images
        report = dataclasses.replace(report, canvas=(max(report.canvas[0], *(i.width for i in images)),
                                                     max(report.canvas[1], *(i.height for i in images))))
    size = f"{report.image_size[0]} x {report.image_size[1]} px" if report.image_size else "image size unknown"
    fps = f", {report.fps:g} fps" if report.fps else ""
    n_frames = report.last_frame - report.first_frame + 1
    drawn = sum(t.drawn for t in report.tracks)
    state_keys = " ".join(f'<span class="key"><i class="{s}" style="border-color:{STATE_COLOURS[s]}"></i>'
                          f'{_e(STATE_TEXT[s])}</span>' for s in STATES)
    title = f"{report.name}: scene report"
    ego_key = ' <span class="key"><i class="ego"></i>ego region (in front)</span>' if report.ego_region else ""
    return f"""<!DOCTYPE html>
<html lang="en" data-report="loading">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{_e(title)}</title>
<style>{CSS}</style>
</head>
<body>
<header>
<h1>{_e(report.name)} <small>scene report</small></h1>
<p class="meta">frames {report.first_frame}-{report.last_frame} ({n_frames} frames{fps}), {size};
{len(report.tracks)} tracks, {report.events} abduced events, {len(report.explanations)} explanations.
Written by <code>refimpl report</code> from a scene of <code>refimpl track --scene</code>.</p>
<p class="tools"><label>show one track:
<input id="filter" type="search" placeholder="e.g. 13 or trk_13" size="16"></label>
<span id="report-status">the page script has not run</span></p>
</header>
<section id="frame">
<h2>Frame <span id="frame-number">{report.frame}</span></h2>
<p class="controls"><button type="button" id="prev" title="previous frame (left arrow)">&#9664;</button>
<input id="slider" type="range" min="{report.first_frame}" max="{report.last_frame}" value="{report.frame}">
<button type="button" id="next" title="next frame (right arrow)">&#9654;</button></p>
<div id="frame-view"></div>
<p class="legend">{state_keys}{ego_key}</p>
<div class="two">
<table class="boxes"><thead><tr><th>track</th><th>type</th><th>state</th><th>box x, y, w, h</th></tr></thead>
<tbody id="frame-rows"></tbody></table>
<div><h3>Fluents and relations</h3><pre id="frame-relations"></pre>
{relation_legend()}</div>
</div>
<p class="note">A halted box is the tracker's Kalman prediction. A track that <i>hides_behind</i> at t and
<i>unhides_from_behind</i> at r is drawn hidden at t .. r-1; the fluent <code>hidden_by</code> holds from t+1
to r (an event sets its fluents from the next frame on).</p>
</section>
<section id="spacetime">
<h2>Space-time picture</h2>
<p class="note">{drawn} of {len(report.tracks)} tracks (those observed in 3 or more frames), by first frame;
time runs left to right. Click to show a frame; the red line is the frame shown above.</p>
{spacetime_svg(report)}
{_legend()}
</section>
<section id="events">
<h2>Events per track</h2>
{events_table(report)}
</section>
<section id="explanations">
<h2>Explanations</h2>
{explanations_list(report)}
</section>
{_json_script(frame_data(report))}
{_images_script(images)}
<script>{SCRIPT}</script>
</body>
</html>
"""


CSS = """
body{font:14px/1.45 system-ui,-apple-system,"Segoe UI",Roboto,sans-serif;margin:0 auto;max-width:1240px;
padding:10px 18px 40px;color:#1d1d1f;background:#fafafa}
h1{font-size:22px;margin:6px 0 2px}h1 small{font-weight:normal;color:#666;font-size:15px}
h2{font-size:17px;margin:22px 0 6px;border-bottom:1px solid #ddd;padding-bottom:3px}h3{font-size:14px;margin:4px 0}
.meta,.note{color:#444;margin:2px 0 6px}.note{font-size:12.5px}
.tools{display:flex;gap:18px;align-items:center;margin:4px 0}#report-status{color:#777;font-size:12px}
.controls{display:flex;gap:8px;align-items:center;margin:2px 0}#slider{flex:1}
button{font:inherit;cursor:pointer}
#frame-view svg{width:100%;height:auto;background:#fff;border:1px solid #ccc}
#frame-view .image{fill:#f4f4f4}#frame-view .ego{fill:#ffe9a8;fill-opacity:.5;stroke:#d4a017}
#frame-view .box rect{fill:none;stroke-width:2.5}#frame-view .box.halted-kind rect{stroke-dasharray:7 4}
#frame-view .box text{font-size:15px;font-weight:600;paint-order:stroke;stroke:#fff;stroke-width:3px}
#frame-view .box.dim{opacity:.18}
.legend{font-size:12px;color:#333;display:flex;flex-wrap:wrap;gap:4px 14px;margin:4px 0}
.key i{display:inline-block;width:18px;height:10px;margin-right:4px;vertical-align:-1px}
.key i.active,.key i.hidden,.key i.missing,.key i.halted{border:2px solid;height:7px;width:16px}
.key i.hidden,.key i.missing,.key i.halted{border-style:dashed}.key i.ego{background:#ffe9a8;border:1px solid #d4a017}
.key svg.mark{width:11px;height:11px;margin-right:3px;vertical-align:-1px}
.two{display:grid;grid-template-columns:minmax(0,3fr) minmax(0,2fr);gap:18px;align-items:start}
table{border-collapse:collapse;width:100%;font-size:12.5px;background:#fff}
th,td{border-bottom:1px solid #e4e4e4;padding:2px 6px;text-align:left;vertical-align:top}th{background:#f0f0f0}
td.state{font-weight:600}
pre{font-size:11.5px;background:#fff;border:1px solid #e4e4e4;padding:4px 6px;max-height:320px;overflow:auto;margin:0}
#spacetime-svg{width:100%;height:auto;background:#fff;border:1px solid #ccc;cursor:crosshair}
#spacetime-svg .label{font-size:10px;text-anchor:end;fill:#333}
#spacetime-svg .tick{font-size:10px;text-anchor:middle;fill:#555}
#spacetime-svg .grid{stroke:#d0d0d0;stroke-dasharray:2 3}
#spacetime-svg .pair{stroke-dasharray:2 2;stroke-width:1}
#spacetime-svg #cursor{stroke:#d62728;stroke-width:1.5}
#spacetime-svg .row.dim,#spacetime-svg .event.dim{opacity:.15}
.ev{border:1px solid var(--c);border-left:5px solid var(--c);background:#fff;border-radius:3px;padding:0 4px;
margin:1px 0;font-size:11.5px;white-space:nowrap}
.chips{line-height:1.9}.none,.empty{color:#888}
.explanations li{margin:1px 0;cursor:pointer}
.hide{display:none}
.codes{display:grid;grid-template-columns:max-content 1fr;gap:0 8px;font-size:11.5px;margin:6px 0 0;color:#333}
.codes dt{font-family:monospace;font-weight:600}.codes dd{margin:0}.codes .head{margin-top:3px;color:#555}
"""

SCRIPT = r"""
(function () {
  "use strict";
  var root = document.documentElement;
  window.addEventListener("error", function (e) { root.setAttribute("data-report", "error: " + e.message); });
  var D = JSON.parse(document.getElementById("report-data").textContent);
  var frame = D.frame, filterId = null;
  var slider = document.getElementById("slider");
  var W = D.canvas[0], H = D.canvas[1];
  var imagesBlock = document.getElementById("report-images");
  var IMG = imagesBlock ? JSON.parse(imagesBlock.textContent) : null;  // frame -> [data URI, width, height]

  function esc(s) {
    return String(s).replace(/&/g, "&amp;").replace(/</g, "&lt;").replace(/>/g, "&gt;").replace(/"/g, "&quot;");
  }
  function trackName(i) { return i < 0 ? "" : D.tracks[i][0]; }

  function drawFrame() {
    var rows = D.frames[frame - D.first], parts = [], table = [];
    parts.push('<svg viewBox="0 0 ' + W + ' ' + H + '" role="img" aria-label="boxes at frame ' + frame + '">');
    parts.push('<rect class="image" x="0" y="0" width="' + W + '" height="' + H + '"/>');
    if (D.ego) {
      parts.push('<rect class="ego" x="' + D.ego[0] + '" y="' + D.ego[2] + '" width="' + (D.ego[1] - D.ego[0]) +
                 '" height="' + (D.ego[3] - D.ego[2]) + '"/>');
    }
    rows.forEach(function (r) {
      var t = D.tracks[r[0]], state = D.states[r[5]], colour = D.stateColours[r[5]];
      var text = D.stateText[r[5]] + (r[6] >= 0 ? " track " + D.tracks[r[6]][1] : "");
      var kind = state === "active" ? "" : " halted-kind";
      var label = String(t[1]) + (r[6] >= 0 ? " \u2190 " + D.tracks[r[6]][1] : "");
      var dim = filterId && t[0] !== filterId && trackName(r[6]) !== filterId ? " dim" : "";
      parts.push('<g class="box ' + state + kind + dim + '" data-track="' + esc(t[0]) + '"><title>' +
                 esc(t[0] + " (" + t[2] + "): " + text) + '</title><rect x="' + r[1] + '" y="' + r[2] +
                 '" width="' + r[3] + '" height="' + r[4] + '" stroke="' + colour + '"/><text class="label" x="' +
                 r[1] + '" y="' + r[2] + '" fill="' + colour + '">' + esc(label) + '</text></g>');
      table.push('<tr data-tracks="' + esc(t[0] + (r[6] >= 0 ? " " + D.tracks[r[6]][0] : "")) + '"><td>' +
                 esc(t[1]) + '</td><td>' + esc(t[2]) + '</td><td class="state" style="color:' + colour + '">' +
                 esc(text) + '</td><td>' + [r[1], r[2], r[3], r[4]].join(", ") + '</td></tr>');
    });
    parts.push("</svg>");
    document.getElementById("frame-view").innerHTML = parts.join("");
    var view = document.querySelector("#frame-view svg"), picture = IMG && IMG[String(frame)];
    if (picture) {  // the frame's own image, under the boxes
      var im = document.createElementNS("http" + "://www.w3.org/2000/svg", "image");
      im.setAttribute("class", "frame-image");
      im.setAttribute("x", 0); im.setAttribute("y", 0);
      im.setAttribute("width", picture[1]); im.setAttribute("height", picture[2]);
      im.setAttribute("preserveAspectRatio", "none");
      im.setAttribute("href", picture[0]);
      view.insertBefore(im, view.children[1]);
    }
    placeLabels(view);
    document.getElementById("frame-rows").innerHTML = table.join("") ||
      '<tr><td colspan="4" class="none">no track has a box at this frame</td></tr>';
    document.getElementById("frame-relations").textContent = D.relations[frame - D.first].join("\n") || "(none)";
    document.getElementById("frame-number").textContent = frame + " (" + rows.length + " boxes" +
      (IMG ? (picture ? ", on its image" : ", no image embedded for this frame") : "") + ")";
    slider.value = frame;
    var cursor = document.getElementById("cursor"), svg = document.getElementById("spacetime-svg");
    if (cursor && svg) {
      var x = Number(svg.dataset.left) + (frame - D.first + 0.5) * Number(svg.dataset.sx);
      cursor.setAttribute("x1", x); cursor.setAttribute("x2", x);
    }
    applyFilter();
    return rows.length;
  }

  // Box labels without overlap: each label in track order takes the first free place of: above its
  // box, below it, inside at the top, inside at the bottom, then stacked further above, then further
  // below (one label height a step), inside the picture; failing all, a row under the picture, which
  // grows to hold it.  Free: its rectangle (getBBox, user units) keeps GAP clear of every placed label.
  var GAP = 1;
  function placeLabels(svg) {
    var placed = [], bottom = H;
    function free(x, y, w, h) {
      return placed.every(function (p) {
        return x + w + GAP <= p[0] || p[0] + p[2] + GAP <= x || y + h + GAP <= p[1] || p[1] + p[3] + GAP <= y;
      });
    }
    svg.querySelectorAll(".box").forEach(function (g) {
      var t = g.querySelector("text"), rect = g.querySelector("rect"), bb = t.getBBox();
      var w = bb.width, h = bb.height, base = Number(t.getAttribute("y")) - bb.y;  // baseline below the top
      var bx = Number(rect.getAttribute("x")), by = Number(rect.getAttribute("y"));
      var bw = Number(rect.getAttribute("width")), bh = Number(rect.getAttribute("height"));
      var x = Math.max(0, Math.min(bx, W - w)), k, spot = null;
      var tops = [by - h - 2, by + bh + 2, by + 2, by + bh - h - 2];
      for (k = 1; k <= 40; k++) { tops.push(by - h - 2 - k * (h + GAP)); }
      for (k = 1; k <= 40; k++) { tops.push(by + bh + 2 + k * (h + GAP)); }
      for (k = 0; k < tops.length && spot === null; k++) {
        if (tops[k] >= 0 && tops[k] + h <= H && free(x, tops[k], w, h)) { spot = tops[k]; }
      }
      for (k = 0; spot === null; k++) {
        if (free(x, H + 2 + k * (h + GAP), w, h)) { spot = H + 2 + k * (h + GAP); }
      }
      placed.push([x, spot, w, h]);
      bottom = Math.max(bottom, spot + h + 2);
      t.setAttribute("x", x.toFixed(1));
      t.setAttribute("y", (spot + base).toFixed(1));
    });
    if (bottom > H) { svg.setAttribute("viewBox", "0 0 " + W + " " + bottom.toFixed(1)); }
    // what a test reads back (the labels' rectangles on the screen, CSS px): left,top,width,height
    svg.querySelectorAll(".box text").forEach(function (t) {
      var c = t.getBoundingClientRect();
      t.setAttribute("data-rect", [c.left, c.top, c.width, c.height].map(function (v) {
        return v.toFixed(2);
      }).join(","));
    });
  }

  function setFrame(f) {
    f = Math.max(D.first, Math.min(D.last, Math.round(f)));
    if (f !== frame) { frame = f; drawFrame(); }
  }

  function applyFilter() {
    document.querySelectorAll("[data-tracks]").forEach(function (el) {
      var ids = el.getAttribute("data-tracks").split(" ");
      el.classList.toggle("hide", filterId !== null && ids.indexOf(filterId) < 0);
    });
    document.querySelectorAll("#spacetime-svg .row, #spacetime-svg .event").forEach(function (el) {
      el.classList.toggle("dim", filterId !== null && el.getAttribute("data-track") !== filterId);
    });
  }

  document.getElementById("filter").addEventListener("input", function (e) {
    var v = e.target.value.trim();
    filterId = v === "" ? null : (/^\d+$/.test(v) ? "trk_" + v : v);
    drawFrame();
  });
  slider.addEventListener("input", function () { setFrame(Number(slider.value)); });
  document.getElementById("prev").addEventListener("click", function () { setFrame(frame - 1); });
  document.getElementById("next").addEventListener("click", function () { setFrame(frame + 1); });
  document.addEventListener("keydown", function (e) {
    if (e.target.tagName === "INPUT" && e.target.type !== "range") { return; }
    if (e.key === "ArrowLeft") { setFrame(frame - 1); } else if (e.key === "ArrowRight") { setFrame(frame + 1); }
  });
  document.querySelectorAll("#events [data-frame], #explanations [data-frame]").forEach(function (el) {
    el.addEventListener("click", function () {
      setFrame(Number(el.getAttribute("data-frame")));
      document.getElementById("frame").scrollIntoView({behavior: "smooth"});
    });
  });
  var st = document.getElementById("spacetime-svg");
  if (st) {
    st.addEventListener("click", function (e) {
      var p = st.createSVGPoint(); p.x = e.clientX; p.y = e.clientY;
      var q = p.matrixTransform(st.getScreenCTM().inverse());
      setFrame(D.first + (q.x - Number(st.dataset.left)) / Number(st.dataset.sx) - 0.5);
    });
  }

  // a link may name the frame and the track to show: report.html#frame=274&track=129
  location.hash.replace(/^#/, "").split("&").forEach(function (kv) {
    var m = /^(frame|track)=(.+)$/.exec(kv);
    if (m && m[1] === "frame" && /^-?\d+$/.test(m[2])) { frame = Math.max(D.first, Math.min(D.last, Number(m[2]))); }
    if (m && m[1] === "track") {
      var v = decodeURIComponent(m[2]);
      document.getElementById("filter").value = v;
      filterId = /^\d+$/.test(v) ? "trk_" + v : v;
    }
  });
  var boxes = drawFrame();
  var bars = document.querySelectorAll("#spacetime-svg .bar").length;
  document.getElementById("report-status").textContent = "rendered: frame " + frame + " with " + boxes +
    " boxes; space-time picture with " + bars + " bars; " + D.explanations + " explanations";
  if (!root.getAttribute("data-report").startsWith("error")) { root.setAttribute("data-report", "rendered"); }
})();
"""


def write_report(scene_path: str, out: str, frame: int | None = None, images: str | None = None,
                 frames: str | None = None) -> str:
    """``refimpl report``: load the scene, write the HTML page to out atomically; a summary line.
    images: the folder of the frame images (refimpl.scene.report_images), frames: which of them."""
    check_outputs({"--out": out}, {"scene": scene_path})
    scene = load_scene(scene_path)
    report = build_report(scene, frame)
    pictures: tuple[FrameImage, ...] = ()
    if images is not None:
        pictures = load_frame_images(images, scene, *image_frames(scene, report.frame, frames))
    elif frames is not None:
        raise SceneError("--image-frames needs --images DIR")
    write_atomic(out, render_html(report, pictures))
    embedded = ""
    if pictures:
        size = sum(len(p.data_uri()) for p in pictures) / 1e6
        embedded = (f"; the images of frames {pictures[0].frame}-{pictures[-1].frame} embedded "
                    f"({len(pictures)} files, {size:.1f} MB)")
    return (f"{report.name}: {len(report.tracks)} tracks, {report.events} events, frame {report.frame} "
            f"({len(report.states_at(report.frame))} boxes){embedded} -> {out}")
