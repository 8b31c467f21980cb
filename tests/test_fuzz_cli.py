"""The scene / CLI-value / output-path fuzzer (tests/tools/fuzz_cli.py, tools.fuzzing.cli_inputs) finds no failure on a seeded run."""

from __future__ import annotations

from tools.fuzzing import cli_inputs as fuzz_cli


def test_seeded_cli_fuzz_run_ends_without_failures():
    results = fuzz_cli.run(24, seed=0)
    assert len(results) == 24 and {r.target for r in results} == set(fuzz_cli.TARGETS)
    failures = [r for r in results if r.outcome in fuzz_cli.FAILURES]
    assert not failures, "\n".join(f"{r.outcome} #{r.index}: {r.detail}" for r in failures[:3])
    # both sides are exercised: some commands succeed, most hostile inputs are refused cleanly
    outcomes = {r.outcome for r in results}
    assert {"ok", "error"} <= outcomes


def test_the_judge_flags_a_leftover_and_a_changed_input(tmp_path):
    inp = tmp_path / "in.txt"
    inp.write_text("a")
    before = fuzz_cli._digest([inp])
    files = fuzz_cli._files(tmp_path)
    (tmp_path / ".out.txt.123.tmp").write_text("partial")
    argv = ["track", "--dets", str(inp)]
    assert fuzz_cli.judge(argv, 2, "refimpl track: error: x\n", None, before, [inp], tmp_path, None, files)[0] == "leftover"
    inp.write_text("b")
    assert fuzz_cli.judge(argv, 2, "refimpl track: error: x\n", None, before, [inp], tmp_path, None, files)[0] == "input-changed"
    assert fuzz_cli.judge(argv, 1, "boom\n", None, fuzz_cli._digest([inp]), [inp], tmp_path, None,
                          fuzz_cli._files(tmp_path))[0] == "traceback"
