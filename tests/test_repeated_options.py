"""A repeated option is never silently dropped (issue 24): a single-valued option given twice is
an error naming it, an option of several values (``--dets A B``) adds a repeated occurrence to its
list, and a repeatable NAME=VALUE option refuses one NAME given twice.  Decided once, in the
parser (refimpl/cli/parser.py), for every option of every command."""

from __future__ import annotations

import argparse
import shutil
from pathlib import Path

import pytest

from refimpl.cli import main
from refimpl.cli.parser import _Append, _Once, _Several, build_parser

REPO = Path(__file__).resolve().parent.parent
DEMO = REPO / "data" / "demo" / "TUD-Campus"
FLAGS = (argparse._StoreTrueAction, argparse._StoreFalseAction, argparse._StoreConstAction, argparse._HelpAction)


def _commands() -> dict[str, argparse.ArgumentParser]:
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(sub.choices)


def _usage_error(argv: list[str], capsys) -> str:
    """The last stderr line of a command line argparse refuses (exit code 2)."""
    with pytest.raises(SystemExit) as stop:
        main(argv)
    assert stop.value.code == 2
    return capsys.readouterr().err.splitlines()[-1]


def _valid_text(action: argparse.Action) -> str:
    """A command-line text the option accepts: its first choice, or the first of a few candidates
    its type parses."""
    if action.choices:
        return str(list(action.choices)[0])
    for text in ("3", "car", "3,4", "x=1", "0.5,0.5,0.5,0.5", "x"):
        try:
            if action.type is not None:
                action.type(text)
            return text
        except (argparse.ArgumentTypeError, ValueError, TypeError):
            continue
    raise AssertionError(f"no sample value for {action.option_strings}")


def test_every_option_of_every_command_says_how_it_repeats():
    # a plain argparse "store" or "append" left anywhere would keep only the last occurrence
    # (or silently let a later NAME win)
    for name, parser in _commands().items():
        for action in parser._actions:
            if not action.option_strings:
                continue
            assert isinstance(action, (_Once, _Several, _Append) + FLAGS), (name, action.option_strings, action)


SINGLE = [(name, action) for name, parser in _commands().items() for action in parser._actions
          if isinstance(action, _Once)]


@pytest.mark.parametrize("command, action", SINGLE, ids=[f"{c}{a.option_strings[0]}" for c, a in SINGLE])
def test_a_single_valued_option_given_twice_is_an_error_naming_it(command, action, capsys):
    flag, text = action.option_strings[0], _valid_text(action)
    with pytest.raises(SystemExit) as stop:
        build_parser().parse_args([command, flag, text, f"{flag}={text}"])
    assert stop.value.code == 2
    last = capsys.readouterr().err.splitlines()[-1]
    assert last.startswith(f"refimpl {command}: error: argument {'/'.join(action.option_strings)}: given twice (")
    assert last.endswith("); it takes one value")


def test_the_options_the_issue_names_are_single_valued(capsys):
    det = str(DEMO / "det" / "det.txt")
    for argv, message in [
        (["--out", "a.txt", "--out", "b.txt"], "argument --out: given twice (a.txt, then b.txt)"),
        (["--format", "mot", "--format", "kitti"], "argument --format: given twice (mot, then kitti)"),
        (["--class", "Car", "--class", "Pedestrian"], "argument --class: given twice (car, then pedestrian)"),
        (["--backend", "cpsat", "--backend", "baseline"], "argument --backend: given twice (cpsat, then baseline)"),
        (["--img-size", "640,480", "--img-size", "1,1"], "argument --img-size: given twice (640,480, then 1,1)"),
        (["--workers", "2", "--workers", "3"], "argument --workers: given twice (2, then 3)"),
    ]:
        assert _usage_error(["track", "--dets", det, *argv], capsys) == f"refimpl track: error: {message}; it takes one value"


def test_one_const_name_given_twice_is_an_error_and_two_names_are_kept(capsys):
    parser = build_parser()
    with pytest.raises(SystemExit):
        parser.parse_args(["track", "--dets", "d", "--const", "iou_thresh=3", "--const", "iou_thresh=4"])
    assert capsys.readouterr().err.splitlines()[-1] == \
        "refimpl track: error: argument --const: iou_thresh given twice (3, then 4); give it once"
    args = parser.parse_args(["track", "--dets", "d", "--const", "iou_thresh=3", "--const", "max_age=4"])
    assert args.const == [("iou_thresh", 3), ("max_age", 4)]


def test_repeated_dets_are_one_list(tmp_path, capsys):
    # --dets A --dets B is --dets A B: both sequences are tracked (it used to keep B only)
    other = tmp_path / "Other" / "det"
    other.mkdir(parents=True)
    shutil.copy(DEMO / "det" / "det.txt", other / "det.txt")
    shutil.copy(DEMO / "seqinfo.ini", other.parent / "seqinfo.ini")
    det = str(DEMO / "det" / "det.txt")
    parser = build_parser()
    assert parser.parse_args(["track", "--dets", det, "--dets", str(other / "det.txt")]).dets == \
        parser.parse_args(["track", "--dets", det, str(other / "det.txt")]).dets == [det, str(other / "det.txt")]
    assert parser.parse_args(["track", "--dets", "a", "b", "--dets", "c"]).dets == ["a", "b", "c"]
    assert main(["track", "--dets", det, "--dets", str(other / "det.txt"), "--out", str(tmp_path / "x.txt")]) == 2
    assert "2 --dets need --out-dir" in capsys.readouterr().err
    assert main(["track", "--dets", det, "--dets", str(other / "det.txt"), "--out-dir", str(tmp_path / "o"),
                 "--quiet"]) == 0
    written = {p.name: p.read_bytes() for p in (tmp_path / "o").iterdir()}
    assert sorted(written) == ["Other.txt", "TUD-Campus.txt"] and written["Other.txt"] == written["TUD-Campus.txt"] != b""


def test_flags_may_repeat_and_a_parse_leaves_no_bookkeeping():
    args = build_parser().parse_args(["track", "--dets", "d", "--quiet", "--quiet", "--no-preset", "--no-preset"])
    assert args.quiet and args.no_preset
    assert not any(key.startswith("_") for key in vars(args))


def test_dets_given_as_nothing_is_an_error(capsys):
    # --dets=-- used to parse as an empty list: exit 0, no file, no word
    assert _usage_error(["track", "--dets=--", "--out", "x.txt"], capsys) == \
        "refimpl track: error: argument --dets: expected at least one value, got '--'"
