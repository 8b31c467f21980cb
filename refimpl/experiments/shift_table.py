"""The table of ``refimpl benchmark NAME... --shift``: HOTA / IDF1 of every tracker under every
detector and camera shift (refimpl.io.shifts), and the markers of the section ``--out FILE``
writes."""

from __future__ import annotations

SHIFTS_BEGIN = "<!-- refimpl benchmark --shift: begin -->"
SHIFTS_END = "<!-- refimpl benchmark --shift: end -->"
"""The markers of the section ``--shift --out FILE`` writes."""


def shift_table(results: dict[str, dict[str, tuple[float, float]]]) -> str:
    """Markdown: a row per shift, a column per tracker (HOTA / IDF1), then each tracker's worst HOTA
    and its largest drop from ``none``."""
    shifts = list(results)
    trackers = list(results[shifts[0]])
    lines = ["| shift | " + " | ".join(trackers) + " |", "|---|" + "---:|" * len(trackers)]
    for s in shifts:
        lines.append(f"| {s} | " + " | ".join(f"{100 * h:.1f} / {100 * i:.1f}" for h, i in
                                                (results[s][t] for t in trackers)) + " |")
    worst = [min(results[s][t][0] for s in shifts) for t in trackers]
    drop = [max(results["none"][t][0] - results[s][t][0] for s in shifts) for t in trackers]
    lines.append("| worst HOTA | " + " | ".join(f"{100 * w:.1f}" for w in worst) + " |")
    lines.append("| largest HOTA drop | " + " | ".join(f"{100 * d:.1f}" for d in drop) + " |")
    return "\n".join(lines)
