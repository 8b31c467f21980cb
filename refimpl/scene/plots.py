"""Pictures of a scene (refimpl.scene): the space-time picture of all tracks, and one frame's boxes.

matplotlib is imported only inside the drawing functions (the ``plot`` extra), by this module
alone (the benchmarks' figures come from :func:`agg_figure` and :func:`colormap`), and only its
object-oriented API with the Agg canvas is used: no pyplot, no global backend switch, no window.

* :func:`plot_timeline`: one row per track over time; observed frames, halted frames that end in
  a resume (hidden or missing, then seen again) and halted frames that end the track, in three
  colours; the events as markers, with a legend; hides_behind / unhides_from_behind joined to
  the occluder's row by a dotted line.
* :func:`plot_frame`: the boxes at one frame (observed solid, halted = Kalman-predicted dashed)
  with track numbers, the ego region shaded, and the pairwise relations that hold listed beside.
"""

from __future__ import annotations


from . import EgoRegion, Scene, SceneError, SceneTrack, frame_relations, frame_runs, load_scene
from ..knowledge.event_table import EVENT_TABLE
from ..core.display import visible
from ..core.spec import natural_key
from ..io.outputs import atomic_file, check_outputs

OBSERVED_COLOUR = "#1f77b4"
RESUMED_COLOUR = "#ff7f0e"
ENDED_COLOUR = "#9a9a9a"

EVENT_STYLE = {name: (e.marker, e.colour, name) for name, e in EVENT_TABLE.items()}
"""event name -> (marker, colour, label), from the event table (refimpl.knowledge.event_table)."""
PAIR_EVENTS = frozenset(name for name, e in EVENT_TABLE.items() if e.arity == 2)
"""Events joined to the second track's row by a dotted line."""

MIN_OBSERVED = 3
"""Tracks observed in fewer frames (the tracker's min_hits) are left out unless named."""


def _matplotlib():
    try:
        from matplotlib.figure import Figure
        from matplotlib.lines import Line2D
        from matplotlib.patches import Patch, Rectangle
    except ImportError:
        raise SceneError("plots need matplotlib: pip install 'refimpl[plot]'") from None
    return Figure, Line2D, Patch, Rectangle


def agg_figure(figsize: tuple[float, float], dpi: int):
    """A matplotlib Figure with its own Agg canvas (no pyplot, no process-wide backend), for the
    benchmarks' plots (refimpl.experiments): this module is the one that imports matplotlib."""
    Figure, _, _, _ = _matplotlib()
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig = Figure(figsize=figsize, dpi=dpi)
    FigureCanvasAgg(fig)
    return fig


def colormap(name: str):
    """matplotlib's colormap of that name (``"viridis"``)."""
    _matplotlib()
    from matplotlib import colormaps

    return colormaps[name]


def _select(scene: Scene, tracks: str | None) -> list[SceneTrack] | None:
    if tracks is None:
        return None
    out = []
    for word in tracks.replace(" ", "").split(","):
        if word:
            out.append(scene.track(f"trk_{word}" if word.isdigit() else word))
    if not out:
        raise SceneError(f"--tracks names no track: {tracks!r}")
    return out


def _range(scene: Scene, frames: str | None) -> tuple[int, int]:
    if frames is None:
        return scene.first_frame, scene.last_frame
    a, sep, b = frames.partition(":")
    try:
        lo = int(a) if a else scene.first_frame
        hi = int(b) if b else scene.last_frame
    except ValueError:
        lo = hi = -1
        sep = ""
    if not sep or lo > hi:
        raise SceneError(f"--frames must be FROM:TO with FROM <= TO, got {frames!r}")
    return lo, hi


def _shown(text: str) -> str:
    """A scene's string as a picture shows it: its control characters escaped (refimpl.core.display),
    and a dollar sign as itself, not the start of matplotlib's mathtext (a track type "a$\\x$" was
    a ParseFatalException traceback)."""
    return visible(text).replace("$", r"\$")


def _label(t: SceneTrack) -> str:
    return _shown(f"{t.number} {t.type}")


def halted_spans(scene: Scene, t: SceneTrack) -> list[tuple[int, int, bool]]:
    """(first, last, resumed) for each run of halted frames: resumed when the frame after it is observed."""
    return [(a, b, t.observed_box(b + 1) is not None) for a, b in frame_runs(f for f, _ in t.halted)]


def plot_timeline(scene: Scene, out: str, tracks: list[SceneTrack] | None = None,
                  frames: tuple[int, int] | None = None) -> int:
    """The space-time picture; returns the number of tracks drawn."""
    Figure, Line2D, Patch, _ = _matplotlib()
    lo, hi = frames or (scene.first_frame, scene.last_frame)
    if tracks is None:
        tracks = [t for t in scene.tracks if len(t.observed) >= MIN_OBSERVED]
    tracks = [t for t in tracks if t.first_frame <= hi and t.last_frame(scene.last_frame) >= lo]
    tracks.sort(key=lambda t: (t.first_frame, natural_key(t.id)))
    if not tracks:
        raise SceneError(f"no track to draw in frames {lo}-{hi}")
    row = {t.id: i for i, t in enumerate(tracks)}
    n = len(tracks)
    fig_h = min(max(3.2, 0.22 * n + 2.2), 40)
    fig = Figure(figsize=(13, fig_h), dpi=110)
    ax = fig.add_subplot(1, 1, 1)
    height = 0.6
    for t in tracks:
        y = row[t.id]
        obs = [(a - 0.5, b - a + 1) for a, b in frame_runs(f for f, _ in t.observed)]
        ax.broken_barh(obs, (y - height / 2, height), facecolors=OBSERVED_COLOUR)
        for a, b, resumed in halted_spans(scene, t):
            ax.broken_barh([(a - 0.5, b - a + 1)], (y - height / 2, height),
                           facecolors=RESUMED_COLOUR if resumed else ENDED_COLOUR)
    used = set()
    for e in scene.events:
        if not lo <= e.time <= hi or not e.event.args:
            continue
        subject = str(e.event.args[0])
        style = EVENT_STYLE.get(e.event.name)
        if subject not in row or style is None:
            continue
        marker, colour, _ = style
        y = row[subject]
        if e.event.name in PAIR_EVENTS and len(e.event.args) == 2:
            other = str(e.event.args[1])
            if other in row:
                ax.plot([e.time, e.time], [y, row[other]], linestyle=":", color=colour, linewidth=0.9, zorder=2)
        ax.plot([e.time], [y], marker=marker, color=colour, markersize=6, linestyle="none", zorder=3,
                markeredgewidth=1.5)
        used.add(e.event.name)
    ax.set_xlim(lo - 1, hi + 1)
    ax.set_ylim(n - 0.5, -0.5)
    step = max(1, n // 60)
    ax.set_yticks(range(0, n, step))
    ax.set_yticklabels([_label(tracks[i]) for i in range(0, n, step)], fontsize=7 if n > 30 else 8)
    ax.set_xlabel("frame")
    ax.set_ylabel("track (number, type), by first frame")
    ax.grid(axis="x", linestyle=":", linewidth=0.5)
    ax.set_title(_shown(f"{scene.name}: space-time picture of {n} tracks, frames {lo}-{hi}"))
    handles = [Patch(color=OBSERVED_COLOUR, label="observed"),
               Patch(color=RESUMED_COLOUR, label="halted, then resumed (hidden / missing)"),
               Patch(color=ENDED_COLOUR, label="halted, then ended (or still halted)")]
    handles += [Line2D([], [], marker=m, color=c, linestyle="none", markeredgewidth=1.5, label=lab)
                for name, (m, c, lab) in EVENT_STYLE.items() if name in used]
    if used & PAIR_EVENTS:
        handles.append(Line2D([], [], color="#d62728", linestyle=":", label="dotted: joins a hidden track to its occluder"))
    fig.legend(handles=handles, loc="lower center", ncol=4, fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, 0.75 / fig_h, 1, 1))  # 0.75 in at the bottom for the legend
    fig.savefig(out, format="png")
    return n


def _frame_figure(Figure, width: float, height: float, lines: list[str]):
    """plot_frame's figure: (figure, image axes, text axes, the columns of relation lines, its
    height in inches).  A wide image (KITTI, 1242 x 375) gets the relations below it in three
    columns, any other beside it."""
    line_h = 0.15  # inches per 8 pt line
    if width / height > 2:  # wide: image on top, relations below in three columns
        img_w = 13.8
        img_h = img_w * height / width
        rows = min(max(-(-len(lines) // 3), 1), 22)
        text_h = 0.45 + rows * line_h
        fig_h = 0.5 + img_h + 0.6 + text_h
        fig = Figure(figsize=(15, fig_h), dpi=110)
        ax = fig.add_axes((0.06, (text_h + 0.6) / fig_h, img_w / 15, img_h / fig_h))
        text = fig.add_axes((0.06, 0.1 / fig_h, 0.92, text_h / fig_h))
        columns = [lines[i * rows:(i + 1) * rows] for i in range(3)]
        if len(lines) > 3 * rows:
            columns[2][-1] = f"... {len(lines) - 3 * rows + 1} more"
    else:  # the image 9 in wide, relations to its right
        img_h = 9.0 * height / width
        fig_h = max(5.5, img_h + 1.4)
        fig = Figure(figsize=(15, fig_h), dpi=110)
        ax = fig.add_axes((0.06, 0.8 / fig_h, 0.6, img_h / fig_h))
        text = fig.add_axes((0.69, 0.8 / fig_h, 0.30, (fig_h - 1.3) / fig_h))
        rows = max(int((fig_h - 1.8) / line_h), 1)
        columns = [lines[:rows]]
        if len(lines) > rows:
            columns[0][-1] = f"... {len(lines) - rows + 1} more"
    return fig, ax, text, columns, fig_h


def _draw_boxes(fig, ax, Rectangle, boxes, width: float, height: float) -> None:
    """Every box of the frame (observed solid, halted dashed) with its track's number on a label
    that no earlier label covers, kept inside the image."""
    cmap = _palette()
    # label size in data units (8 pt digits: about 0.075 in each, 0.17 in high with the padding)
    ax_w_in = ax.get_position().width * fig.get_figwidth()
    per_in = width / ax_w_in
    placed: list[tuple[float, float, float, float]] = []
    for t, kind, b in boxes:
        colour = cmap[hash_number(t) % len(cmap)]
        ax.add_patch(Rectangle((b[0], b[1]), b[2], b[3], fill=False, edgecolor=colour, linewidth=1.8,
                               linestyle="-" if kind == "observed" else "--", zorder=2))
        # observed: the number just above the top-left corner; halted: just below the bottom-left
        # corner; moved down past labels already placed, and kept inside the image
        lw, lh = (0.075 * len(str(t.number)) + 0.06) * per_in, 0.17 * per_in
        x = min(max(b[0], 0.0), width - lw)
        y = b[1] - lh - 2 if kind == "observed" else b[1] + b[3] + 2
        y = min(max(y, 0.0), height - lh)
        for _ in range(6):
            if not any(x < px + pw and px < x + lw and y < py + ph and py < y + lh for px, py, pw, ph in placed):
                break
            y = min(y + lh, height - lh)
        placed.append((x, y, lw, lh))
        ax.text(x + 0.02 * per_in, y + lh / 2, _shown(str(t.number)), color="white", fontsize=8, zorder=3, va="center",
                bbox=dict(facecolor=colour, edgecolor="none", pad=1.0, alpha=0.9))


def plot_frame(scene: Scene, frame: int, out: str, tracks: list[SceneTrack] | None = None,
               region: EgoRegion | None = None) -> int:
    """One frame: boxes (observed solid, halted dashed), ids, the ego region, the relations listed; number of boxes.

    A wide image (KITTI, 1242 x 375) gets the relations below it in three columns, any other
    beside it.
    """
    Figure, Line2D, _, Rectangle = _matplotlib()
    if not scene.first_frame <= frame <= scene.last_frame:
        raise SceneError(f"frame {frame} is outside the scene ({scene.first_frame}-{scene.last_frame})")
    chosen = tracks if tracks is not None else list(scene.tracks)
    boxes = [(t, *t.box_at(frame)) for t in chosen if t.box_at(frame) is not None]
    region = region or EgoRegion()
    size = scene.image_size
    if size:
        width, height = size
    else:
        width = max([b[0] + b[2] for _, _, b in boxes] + [100.0])
        height = max([b[1] + b[3] for _, _, b in boxes] + [100.0])
    lines = frame_relation_lines(scene, frame, [t for t, _, _ in boxes])
    title = f"relations at frame {frame} (A B: relations of A to B)"
    fig, ax, text, columns, fig_h = _frame_figure(Figure, width, height, lines)
    ax.set_xlim(0, width)
    ax.set_ylim(height, 0)
    ax.set_aspect("equal")
    if size:
        xa, xb, ya, yb = region.pixels(size)
        ax.add_patch(Rectangle((xa, ya), xb - xa, yb - ya, facecolor="#ffe9a8", edgecolor="#d4a017",
                               alpha=0.45, linewidth=1, zorder=0))
    _draw_boxes(fig, ax, Rectangle, boxes, width, height)
    ax.set_xlabel("x (px)")
    ax.set_ylabel("y (px)")
    ax.set_title(_shown(f"{scene.name}, frame {frame}: {len(boxes)} tracks"))
    legend = [Line2D([], [], color="#444444", linewidth=1.8, label="observed"),
              Line2D([], [], color="#444444", linewidth=1.8, linestyle="--", label="halted (predicted box)")]
    if size:
        legend.append(Rectangle((0, 0), 1, 1, facecolor="#ffe9a8", edgecolor="#d4a017", alpha=0.45,
                                label="ego region (in front)"))
    ax.legend(handles=legend, loc="upper right", ncol=3, fontsize=8, framealpha=0.85)
    text.axis("off")
    text.text(0, 1, _shown(title), va="top", ha="left", fontsize=9, weight="bold", transform=text.transAxes)
    for i, col in enumerate(columns):
        text.text(i / max(len(columns), 1), 1 - 0.3 / (text.get_position().height * fig_h),
                  "\n".join(map(_shown, col or (["(none)"] if i == 0 else []))), va="top", ha="left", family="monospace",
                  fontsize=8, transform=text.transAxes)
    fig.savefig(out, format="png")
    return len(boxes)


def frame_relation_lines(scene: Scene, frame: int, tracks: list[SceneTrack]) -> list[str]:
    """The fluents that hold at the frame (clipped true, hidden_by true), then for each pair of
    tracks in contact or near each other its relations (observed or predicted boxes).

    The fluents are read from the scene's timelines, which hold ``holds_at`` of every frame
    (refimpl.scene.fluent_timelines), instead of replaying the event log for each track."""
    order = {t.id: i for i, t in enumerate(scene.tracks)}
    hiders: dict[str, list[str]] = {}  # T1 -> every T2 of a recorded hidden_by(T1,T2), in scene order
    for atom, _ in scene.timelines:
        if atom.startswith("hidden_by("):
            t1, t2 = atom[len("hidden_by("):-1].split(",")
            hiders.setdefault(t1, []).append(t2)
    lines = []
    for t in tracks:
        candidates = [f"clipped({t.id})"] + [f"hidden_by({t.id},{x})" for x in
                                             sorted(hiders.get(t.id, ()), key=lambda x: order.get(x, len(order)))]
        lines += [atom for atom in candidates
                  if any(a <= frame <= b and v == "true" for a, b, v in scene.timeline(atom))]
    ordered = sorted(tracks, key=lambda t: natural_key(t.id))
    for i, a in enumerate(ordered):
        for b in ordered[i + 1:]:
            ba, bb = a.box_at(frame)[1], b.box_at(frame)[1]  # type: ignore[index]
            found = frame_relations(ba, bb)
            if found[0] == "dc" and "near" not in found:
                continue
            lines.append(f"{a.number:>4} {b.number:<4} " + ", ".join(found))
    return lines


def hash_number(t: SceneTrack) -> int:
    n = t.number
    return n if isinstance(n, int) else sum(map(ord, n))


def _palette() -> list[str]:
    return ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#8c564b", "#e377c2", "#17becf", "#bcbd22",
            "#ff7f0e", "#7f7f7f", "#393b79", "#637939", "#8c6d31", "#843c39", "#7b4173", "#3182bd"]


def plot_scene_file(scene_path: str, out: str, frame: int | None = None, tracks: str | None = None,
                    frames: str | None = None) -> str:
    """``refimpl plot``: load the scene, draw the space-time picture (or one frame) to out; a summary line."""
    check_outputs({"--out": out}, {"scene": scene_path})
    scene = load_scene(scene_path)
    chosen = _select(scene, tracks)
    if frame is not None:
        with atomic_file(out, binary=True) as fh:
            n = plot_frame(scene, frame, fh, chosen)
        return f"{scene.name} frame {frame}: {n} boxes -> {out}"
    lo, hi = _range(scene, frames)
    with atomic_file(out, binary=True) as fh:
        n = plot_timeline(scene, fh, chosen, (lo, hi))
    return f"{scene.name} frames {lo}-{hi}: {n} tracks -> {out}"
