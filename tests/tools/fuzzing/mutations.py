"""The mutations applied to a seed file: truncated lines, dropped / duplicated / swapped fields,
bad numbers, duplicated or deleted lines, renamed ids, frames out of order, long lines, control
characters, empty files, binary garbage, invalid UTF-8, CRLF / CR endings, byte-order marks."""

from __future__ import annotations

import random
import re
from dataclasses import dataclass, field
from typing import Callable


BAD_NUMBERS = (
    "abc", "", " ", "NaN", "nan", "-nan", "inf", "-inf", "Infinity", "1e309", "-1e309", "1e308",
    "1.7976931348623157e308", str(2 ** 31), str(-2 ** 31 - 1), str(2 ** 53 + 1), str(2 ** 63),
    str(2 ** 64), str(10 ** 30), "2147483647", "-2147483648", "1000000", "-1000000", "999999999", "9" * 400, "-" + "9" * 40, "99999", "-1", "0", "-0", "0.0", "-5",
    "1.5", "0.5", "0.004", "1e-9", "5e-324", "0x1F", "1_000", "+3", "1e2", "٣", "None", "1,5",
    "1 5", "'7'", "7.", ".", "-", "e", "1e", "--1",
)
NAMES = ("det_999", "trk_999", "det_0", "trk_0", "Det_1", "x", "_", "active", "running", "car",
         "Car", "det-1", "42", "f(a)", "a b", "\"q\"")
CONTROL = ("\x00", "\t", "\x0b", "\x0c", "\x1c", "\x85", "\u2028", "\u2029", "\r", "\x7f", "\ufeff")
_NUM = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
_NAME = re.compile(r"[a-z_][A-Za-z0-9_]*")


@dataclass
class Doc:
    """A file under construction: lines without line ends, plus how to encode them."""

    lines: list[str]
    sep: str | None  # field separator (None: fact syntax)
    eol: str = "\n"
    final_eol: bool = True
    prefix: bytes = b""
    encoding: str = "utf-8"
    raw: bytes | None = None  # replaces everything when set
    byte_edits: list[Callable[[bytes], bytes]] = field(default_factory=list)

    def to_bytes(self) -> bytes:
        if self.raw is not None:
            return self.raw
        text = self.eol.join(self.lines) + (self.eol if self.final_eol and self.lines else "")
        data = self.prefix + text.encode(self.encoding, errors="surrogatepass")
        for edit in self.byte_edits:
            data = edit(data)
        return data


def _pick_line(doc: Doc, rng: random.Random) -> int | None:
    idx = [i for i, l in enumerate(doc.lines) if l.strip() and not l.lstrip().startswith("%")]
    return rng.choice(idx) if idx else None


def _split_fields(line: str, sep: str | None) -> tuple[str, list[str], str, str]:
    """(prefix, fields, suffix, joiner) of a data line or a fact name(arg,...)."""
    if sep is not None:
        return "", line.split(sep), "", sep
    m = re.match(r"^(\s*[^()]*\()(.*)(\)\s*\.\s*)$", line)
    if not m:
        return "", line.split(), "", " "
    args, depth, cur = [], 0, ""
    for ch in m.group(2):
        if ch == "," and depth == 0:
            args.append(cur)
            cur = ""
            continue
        depth += ch == "("
        depth -= ch == ")"
        cur += ch
    args.append(cur)
    return m.group(1), args, m.group(3), ","


def _edit_fields(doc: Doc, rng: random.Random, how: str) -> str:
    i = _pick_line(doc, rng)
    if i is None:
        return "no-op"
    pre, fields, post, joiner = _split_fields(doc.lines[i], doc.sep)
    if how == "drop" and fields:
        del fields[rng.randrange(len(fields))]
    elif how == "dup" and fields:
        k = rng.randrange(len(fields))
        fields.insert(k, fields[k])
    elif how == "swap" and len(fields) > 1:
        a, b = rng.sample(range(len(fields)), 2)
        fields[a], fields[b] = fields[b], fields[a]
    elif how == "extra":
        fields.append(rng.choice(("1", "", "x", "-1", "0.5")))
    doc.lines[i] = pre + joiner.join(fields) + post
    return f"{how}-field line {i + 1}"


def m_truncate_line(doc, rng):
    i = _pick_line(doc, rng)
    if i is None:
        return "no-op"
    line = doc.lines[i]
    doc.lines[i] = line[:rng.randrange(len(line))]
    return f"truncate line {i + 1}"


def m_drop_field(doc, rng):
    return _edit_fields(doc, rng, "drop")


def m_dup_field(doc, rng):
    return _edit_fields(doc, rng, "dup")


def m_swap_fields(doc, rng):
    return _edit_fields(doc, rng, "swap")


def m_extra_field(doc, rng):
    return _edit_fields(doc, rng, "extra")


def m_replace_number(doc, rng):
    i = _pick_line(doc, rng)
    if i is None:
        return "no-op"
    line = doc.lines[i]
    nums = list(_NUM.finditer(line))
    if not nums:
        return "no-op"
    m = rng.choice(nums)
    value = rng.choice(BAD_NUMBERS)
    doc.lines[i] = line[:m.start()] + value + line[m.end():]
    return f"number {m.group()!r} -> {value!r} line {i + 1}"


def m_replace_first_number(doc, rng):
    """The frame (MOT / KITTI) or the first argument: zero, negative, huge, fractional, text."""
    i = _pick_line(doc, rng)
    if i is None:
        return "no-op"
    line = doc.lines[i]
    m = _NUM.search(line)
    if not m:
        return "no-op"
    value = rng.choice(("0", "-1", "1.5", "99999", "1e20", "nan", "x", "", str(2 ** 63), "1e0"))
    doc.lines[i] = line[:m.start()] + value + line[m.end():]
    return f"first number {m.group()!r} -> {value!r} line {i + 1}"


def m_size_zero_negative(doc, rng):
    """A width / height (or x2 / y2) made zero or negative."""
    i = _pick_line(doc, rng)
    if i is None:
        return "no-op"
    pre, fields, post, joiner = _split_fields(doc.lines[i], doc.sep)
    cols = {",": (4, 5), " ": (8, 9), None: (3, 4)}.get(doc.sep, (4, 5))
    if doc.sep is None and not doc.lines[i].lstrip().startswith("box2d"):
        return "no-op"
    if len(fields) <= max(cols):
        return "no-op"
    col = rng.choice(cols)
    fields[col] = rng.choice(("0", "-1", "-0.5", "0.0", "0.001", "0.004", "1e-300", "-1e300",
                              fields[col - 2] if doc.sep == " " else "0"))
    doc.lines[i] = pre + joiner.join(fields) + post
    return f"size field {col + 1} -> {fields[col]!r} line {i + 1}"


def m_dup_line(doc, rng):
    i = _pick_line(doc, rng)
    if i is None:
        return "no-op"
    j = rng.randrange(len(doc.lines) + 1)
    doc.lines.insert(j, doc.lines[i])
    return f"duplicate line {i + 1} at {j + 1}"


def m_delete_line(doc, rng):
    i = _pick_line(doc, rng)
    if i is None:
        return "no-op"
    del doc.lines[i]
    return f"delete line {i + 1}"


def m_rename_id(doc, rng):
    """Facts: rename an id in an iou fact (or any fact); tables: give a row another row's id."""
    if doc.sep is None:
        cand = [i for i, l in enumerate(doc.lines) if l.lstrip().startswith("iou(")] or \
               [i for i, l in enumerate(doc.lines) if "(" in l]
        if not cand:
            return "no-op"
        i = rng.choice(cand)
        names = [m for m in _NAME.finditer(doc.lines[i]) if m.start() > doc.lines[i].find("(")]
        if not names:
            return "no-op"
        m = rng.choice(names)
        new = rng.choice(NAMES)
        doc.lines[i] = doc.lines[i][:m.start()] + new + doc.lines[i][m.end():]
        return f"rename {m.group()} -> {new} line {i + 1}"
    i, j = _pick_line(doc, rng), _pick_line(doc, rng)
    if i is None or j is None:
        return "no-op"
    fi, fj = doc.lines[i].split(doc.sep), doc.lines[j].split(doc.sep)
    if len(fi) < 2 or len(fj) < 2:
        return "no-op"
    fi[0], fi[1] = fj[0], fj[1]  # same frame and id as line j: a duplicate (frame, id)
    doc.lines[i] = doc.sep.join(fi)
    return f"line {i + 1} gets frame,id of line {j + 1}"


def m_shuffle_frames(doc, rng):
    """Frames out of order: shuffle whole frames, or all lines."""
    if doc.sep is None or rng.random() < 0.3:
        rng.shuffle(doc.lines)
        return "shuffle lines"
    groups: dict[str, list[str]] = {}
    for line in doc.lines:
        groups.setdefault(line.split(doc.sep)[0], []).append(line)
    keys = list(groups)
    rng.shuffle(keys)
    doc.lines = [l for k in keys for l in groups[k]]
    return "shuffle frames"


def m_swap_frame_numbers(doc, rng):
    i, j = _pick_line(doc, rng), _pick_line(doc, rng)
    if i is None or j is None or doc.sep is None:
        return "no-op"
    fi, fj = doc.lines[i].split(doc.sep), doc.lines[j].split(doc.sep)
    fi[0], fj[0] = fj[0], fi[0]
    doc.lines[i], doc.lines[j] = doc.sep.join(fi), doc.sep.join(fj)
    return f"swap frame numbers of lines {i + 1}, {j + 1}"


def m_rename_symbol(doc, rng):
    i = _pick_line(doc, rng)
    if i is None:
        return "no-op"
    names = list(_NAME.finditer(doc.lines[i])) if doc.sep is None else \
        list(re.finditer(r"[A-Za-z_]+", doc.lines[i]))
    if not names:
        return "no-op"
    m = rng.choice(names)
    new = rng.choice(NAMES + ("curr_time", "det", "box2d", "occurs_at", "DontCare", "Tram", "car"))
    doc.lines[i] = doc.lines[i][:m.start()] + new + doc.lines[i][m.end():]
    return f"symbol {m.group()} -> {new} line {i + 1}"


def m_facts_specific(doc, rng):
    """Fact-file edits: remove / duplicate curr_time, conf / iou / state / history out of range."""
    if doc.sep is not None:
        return m_replace_number(doc, rng)
    choice = rng.randrange(7)
    if choice == 0:
        doc.lines = [l for l in doc.lines if "curr_time" not in l]
        return "remove curr_time"
    if choice == 1:
        doc.lines.append(rng.choice(("#const curr_time=3.", "#const iou_thresh=1.", "#const x=.",
                                     "#const curr_time = -7 .", "#const", "#constcurr_time=1.")))
        return f"append {doc.lines[-1]!r}"
    if choice == 2:
        doc.lines.append(rng.choice(("occurs_at(lost(trk_0),100000).", "occurs_at(x,-5).",
                                     "occurs_at(f(g(h(1,2),a),b),1).", "occurs_at(1,2).",
                                     "trk_state(trk_77, active).", "box2d(ghost, 1, 2, 3, 4).",
                                     "det(det_0, car, 101).", "iou(trk_0,det_0,100001).",
                                     "iou(trk_ghost,det_0,5).", "match_type(car).", "foo.",
                                     "det(det_x, car, -1).", "trk(trk_new, car).")))
        return f"append {doc.lines[-1]!r}"
    if choice == 3:  # deep nesting
        depth = rng.choice((50, 500, 5000, 50000))
        doc.lines.append("occurs_at(" + "f(" * depth + "a" + ")" * depth + ",1).")
        return f"deeply nested term (depth {depth})"
    if choice == 4:  # several facts on one line / a fact split over two lines
        i = _pick_line(doc, rng)
        if i is None or i + 1 >= len(doc.lines):
            return "no-op"
        if rng.random() < 0.5:
            doc.lines[i:i + 2] = [doc.lines[i] + " " + doc.lines[i + 1]]
            return f"join lines {i + 1},{i + 2}"
        line = doc.lines[i]
        k = rng.randrange(1, max(2, len(line)))
        doc.lines[i:i + 1] = [line[:k], line[k:]]
        return f"split line {i + 1} at {k}"
    if choice == 5:
        i = _pick_line(doc, rng)
        if i is None:
            return "no-op"
        doc.lines[i] = doc.lines[i].rstrip().rstrip(".") + rng.choice(("", ",", ";", ". %", ".."))
        return f"fact terminator changed line {i + 1}"
    i = _pick_line(doc, rng)
    if i is None:
        return "no-op"
    doc.lines[i] = doc.lines[i] + rng.choice((" % comment", "%", " %% (", " det(det_0, car, 5)."))
    return f"trailing text line {i + 1}"


def m_long_line(doc, rng):
    i = _pick_line(doc, rng)
    if i is None:
        return "no-op"
    kind = rng.randrange(3)
    if kind == 0:
        doc.lines[i] = doc.lines[i] + "7" * rng.choice((1000, 100_000, 1_000_000))
        return f"very long number line {i + 1}"
    if kind == 1:
        sep = doc.sep if doc.sep is not None else ","
        doc.lines[i] = doc.lines[i] + (sep + "1") * rng.choice((100, 10_000))
        return f"very many fields line {i + 1}"
    doc.lines.insert(i, "x" * rng.choice((10_000, 1_000_000)))
    return f"very long text line before {i + 1}"


def m_control_char(doc, rng):
    i = _pick_line(doc, rng)
    if i is None:
        return "no-op"
    line = doc.lines[i]
    k = rng.randrange(len(line) + 1)
    ch = rng.choice(CONTROL)
    doc.lines[i] = line[:k] + ch + line[k:]
    return f"insert {ch!r} line {i + 1} col {k + 1}"


def m_garbage_line(doc, rng):
    k = rng.randrange(len(doc.lines) + 1)
    alphabet = "abcXYZ0123456789,.;:()[]{}#%-+= \t\"'\\/"
    doc.lines.insert(k, "".join(rng.choice(alphabet) for _ in range(rng.randrange(1, 60))))
    return f"garbage line at {k + 1}"


def m_header_or_comment(doc, rng):
    line = rng.choice(("frame,id,x,y,w,h,score", "# comment", "% comment", "   ", "\t", "[Sequence]"))
    k = rng.choice((0, len(doc.lines)))
    doc.lines.insert(k, line)
    return f"insert {line!r} at {k + 1}"


def m_empty(doc, rng):
    kind = rng.randrange(4)
    doc.lines = [[], [""], ["", "  ", "\t"], ["% only a comment"]][kind]
    return "empty file" if kind == 0 else "blank / comment-only file"


def m_binary(doc, rng):
    doc.raw = rng.randbytes(rng.choice((1, 16, 300, 5000)))
    return "binary garbage"


def m_invalid_utf8(doc, rng):
    bad = rng.choice((b"\xff", b"\xc3\x28", b"\xe2\x82", b"\xed\xa0\x80", b"\x80\x80", b"\xf8\x88\x80\x80\x80"))

    def edit(data: bytes) -> bytes:
        k = rng.randrange(len(data) + 1)
        return data[:k] + bad + data[k:]

    doc.byte_edits.append(edit)
    return f"invalid UTF-8 {bad!r}"


def m_truncate_file(doc, rng):
    def edit(data: bytes) -> bytes:
        return data[:rng.randrange(len(data) + 1)]

    doc.byte_edits.append(edit)
    return "truncate file at a random byte"


def m_crlf(doc, rng):
    doc.eol = rng.choice(("\r\n", "\r"))
    return f"line ends {doc.eol!r}"


def m_no_final_newline(doc, rng):
    doc.final_eol = False
    return "no final newline"


def m_bom(doc, rng):
    if rng.random() < 0.7:
        doc.prefix = b"\xef\xbb\xbf"
        return "UTF-8 BOM"
    doc.encoding = "utf-16"
    return "UTF-16 with BOM"


def m_whitespace(doc, rng):
    i = _pick_line(doc, rng)
    if i is None:
        return "no-op"
    sep = doc.sep if doc.sep is not None else ","
    new = rng.choice((sep + " ", " " + sep, "\t", "  ", sep + sep))
    doc.lines[i] = ("  " + doc.lines[i] + " \t") if rng.random() < 0.3 else doc.lines[i].replace(sep, new)
    return f"whitespace / separators line {i + 1}"


MUTATIONS: list[tuple[Callable[[Doc, random.Random], str], int]] = [
    (m_truncate_line, 8), (m_drop_field, 6), (m_dup_field, 4), (m_swap_fields, 5), (m_extra_field, 3),
    (m_replace_number, 14), (m_replace_first_number, 5), (m_size_zero_negative, 5), (m_dup_line, 6),
    (m_delete_line, 4), (m_rename_id, 6), (m_shuffle_frames, 4), (m_swap_frame_numbers, 3),
    (m_rename_symbol, 4), (m_facts_specific, 6), (m_long_line, 2), (m_control_char, 4),
    (m_garbage_line, 3), (m_header_or_comment, 2), (m_empty, 2), (m_binary, 2), (m_invalid_utf8, 3),
    (m_truncate_file, 3), (m_crlf, 3), (m_no_final_newline, 2), (m_bom, 3), (m_whitespace, 3),
]
_OPS = [m for m, _ in MUTATIONS]
_WEIGHTS = [w for _, w in MUTATIONS]
