"""Every passage the docs present as the paper's words is in the paper, verbatim (issue 26, item 5).

The convention (CONTRIBUTING.md, "Quoting the paper"): a passage is presented as the paper's
words when it is a double-quoted string ("...") that

* stands in a blockquote (lines starting with ``>``), or
* is followed at once (up to a comma, semicolon or closing bracket) by a parenthesised place in
  the paper: ``(Section ...``, ``(Appendix ...``, ``(Step ...``, ``(Table ...``, ``(Fig...``, or
* follows a place or the paper itself: ``Section 4.1.2 ("``, ``(Section 4.1.2, "``, ``Appendix A ("``,
  ``the paper's "``, ``the paper: "``, ``caption "``.

Such a string must occur in the paper's LaTeX text (../shared/paper/) modulo whitespace, case of
its first letter and LaTeX markup (commands like \\emph{...} and \\small, math dollars, braces,
escaped underscores).  An ellipsis ("..." or "…") marks an omission: each piece must occur, in
order; so does an editorial insertion in square brackets ("[Ma et al.]" for a citation command).
Anything else in double quotes (our own words, labels, output) is not a quote of the paper.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
PAPER_DIR = REPO.parent / "shared" / "paper"
DOCS = sorted((REPO / "docs").glob("*.md")) + [REPO / "README.md", REPO / "CONTRIBUTING.md"]

_PLACE = r"(?:Section|Sections|Appendix|Step|Table|Fig\.?|Figure|Algorithm)"
_AFTER = re.compile(r"^[,;)\]]?\s*\(" + _PLACE)
_BEFORE = re.compile(r"(?:" + _PLACE + r"[^()\n]{0,30}\(|\(" + _PLACE + r"[^()\n\"]{0,30}, |the paper'?s?:? |caption )$")
_QUOTED = re.compile(r'"([^"]{8,}?)"', re.S)


def paper_text() -> str:
    files = sorted(PAPER_DIR.glob("*.txt"))
    if not files:
        pytest.skip(f"the paper's text is not at {PAPER_DIR}")
    return "\n".join(f.read_text(encoding="utf-8", errors="replace") for f in files)


def without_footnotes(text: str) -> str:
    """The running text: every \\footnote{...} (nested braces included) left out."""
    out, i = [], 0
    while (j := text.find("\\footnote{", i)) >= 0:
        out.append(text[i:j])
        depth, k = 1, j + len("\\footnote{")
        while k < len(text) and depth:
            depth += {"{": 1, "}": -1}.get(text[k], 0)
            k += 1
        i = k
    return "".join(out) + text[i:]


def normalise_latex(text: str) -> str:
    text = re.sub(r"(?<!\\)%.*", "", text)  # comments
    text = text.replace("\\_", "_").replace("\\&", "&").replace("\\%", "%").replace("~", " ")
    text = re.sub(r"\\textbackslash\s*", "\\\\", text)
    text = re.sub(r"\\(?:emph|textbf|textit|texttt|mathsf|mathit|mathrm|mathcal|textsf|predThF|predTh|aspMeta|text|mbox)\s*",
                  "", text)
    text = re.sub(r"\\(?:small|footnotesize|scriptsize|sffamily|ttfamily|bfseries|itshape|normalsize|large|bf|it)\b\s*",
                  "", text)
    for name, char in (("theta", "θ"), ("phi", "φ"), ("Phi", "Φ"), ("Theta", "Θ")):
        text = re.sub(r"\\" + name + r"\b\s*", char, text)
    text = re.sub(r"\\(?:langle|rangle)", lambda m: "<" if m.group(0) == "\\langle" else ">", text)
    text = text.replace("$", "").replace("{", "").replace("}", "").replace("\\\\", " ")
    return normalise(text)


def normalise(text: str) -> str:
    return "".join(text.split())  # modulo whitespace: none is compared


def normalise_doc(quote: str) -> str:
    quote = re.sub(r"(?m)^\s*>\s?", "", quote)  # blockquote markers inside a wrapped quote
    quote = quote.replace("`", "").replace("**", "").replace("\\_", "_")
    quote = re.sub(r"(?<![\w*])\*(?=\S)([^*]+?)\*(?![\w*])", r"\1", quote)  # *emphasis*
    return normalise(quote)


def _in_blockquote(text: str, start: int) -> bool:
    line_start = text.rfind("\n", 0, start) + 1
    return text[line_start:start].lstrip().startswith(">")


def presented_quotes(text: str) -> list[tuple[int, str]]:
    """(line, quoted text) of every passage the convention above presents as the paper's words."""
    out = []
    offset = 0
    for para in re.split(r"(\n\s*\n)", text):  # quotes never span paragraphs: a stray " stays local
        for m in _QUOTED.finditer(para):
            before, after = para[max(0, m.start() - 60):m.start()], para[m.end():m.end() + 30]
            if _in_blockquote(para, m.start()) or _AFTER.search(after) or _BEFORE.search(before):
                out.append((text.count("\n", 0, offset + m.start()) + 1, m.group(1)))
        offset += len(para)
    return out


def paper_versions() -> tuple[str, str]:
    """The paper normalised, with its footnotes inline and without them (a quote of the running
    text may leave a footnote out; a quote of a footnote is found in the first)."""
    text = paper_text()
    return normalise_latex(text), normalise_latex(without_footnotes(text))


def found_in(quote: str, paper: str) -> bool:
    pieces = [p.strip(",.;:") for p in re.split(r"\.\.\.|…|\[[^\]]*\]", normalise_doc(quote))]
    pieces = [p for p in pieces if p]
    at = 0
    for p in pieces:
        variants = {p, p[:1].swapcase() + p[1:]}
        hits = [paper.find(v, at) for v in variants]
        hits = [h for h in hits if h >= 0]
        if not hits:
            return False
        at = min(hits) + len(p)
    return True


def all_quotes() -> list[tuple[str, int, str]]:
    return [(doc.relative_to(REPO).as_posix(), line, q)
            for doc in DOCS for line, q in presented_quotes(doc.read_text(encoding="utf-8"))]


def test_every_passage_presented_as_the_papers_words_is_verbatim_in_the_paper():
    versions = paper_versions()
    quotes = all_quotes()
    assert len(quotes) >= 20  # docs/model.md alone quotes the paper rule by rule
    missing = [f"{doc}:{line}: \"{' '.join(q.split())[:100]}\"" for doc, line, q in quotes
               if not any(found_in(q, paper) for paper in versions)]
    assert not missing, "not in the paper:\n" + "\n".join(missing)


def test_the_check_finds_a_misquote_and_accepts_markup_and_omissions():
    paper = normalise_latex(r"we can hypothesize that the {\sffamily\small car} got \emph{occluded} and"
                            r" anticipate its reappearance based on the perceived scene dynamics. The event"
                            r" $hides\_behind/2$ is possible.")
    assert found_in("we can hypothesize that the car got occluded and anticipate its reappearance", paper)
    assert found_in("We can hypothesize ... the perceived scene dynamics", paper)
    assert found_in("The event `hides_behind/2` is possible", paper)
    assert not found_in("a car that is hidden behind a bus is still remembered", paper)
    assert not found_in("the perceived scene dynamics ... we can hypothesize", paper)  # order counts
    assert normalise_latex(without_footnotes(r"answers\footnote{a {\sffamily note}} that")) == "answersthat"
    doc = ('> "we can hypothesize that the car got occluded"\n'
           'as "a quote of ours that names no place" and "the event is possible" (Section 3).\n')
    assert [q for _, q in presented_quotes(doc)] == ["we can hypothesize that the car got occluded",
                                                      "the event is possible"]
