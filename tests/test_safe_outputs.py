"""Safe outputs (issue 17, case 1): nothing a command writes can destroy an input, another output,
a symlink, a device node or a FIFO; outputs are checked before the run and land atomically."""

from __future__ import annotations

import os
import shutil
import stat
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from refimpl.cli import main
from refimpl.io import read_mot_results
from refimpl.io.outputs import OutputError, OutputSet, check_outputs

REPO = Path(__file__).resolve().parent.parent
DEMO = REPO / "data" / "demo" / "TUD-Campus"


@pytest.fixture
def seq(tmp_path) -> Path:
    """A private copy of the demo sequence (det/det.txt + seqinfo.ini), so a bug cannot harm the repo."""
    shutil.copytree(DEMO, tmp_path / "TUD-Campus")
    return tmp_path / "TUD-Campus" / "det" / "det.txt"


def _track(dets, *extra) -> list[str]:
    return ["track", "--dets", str(dets), "--backend", "baseline", *map(str, extra)]


def _one_error_line(capsys) -> str:
    err = [line for line in capsys.readouterr().err.splitlines() if line]
    assert len(err) == 1, err
    return err[0]


@pytest.mark.parametrize("case", ["out=dets", "out=symlink-to-dets", "out=hardlink-to-dets", "events=out",
                                  "events-json=dets", "scene=out"])
def test_an_output_equal_to_an_input_or_another_output_is_refused_before_any_work(seq, tmp_path, capsys, case):
    before = seq.read_bytes()
    out = tmp_path / "res.txt"
    link = tmp_path / "link.txt"
    argv = {"out=dets": _track(seq, "--out", seq),
            "out=symlink-to-dets": _track(seq, "--out", link),
            "out=hardlink-to-dets": _track(seq, "--out", link),
            "events=out": _track(seq, "--out", out, "--events", out),
            "events-json=dets": _track(seq, "--out", out, "--events-json", seq),
            "scene=out": ["track", "--dets", str(seq), "--backend", "cpsat", "--out", str(out), "--scene", str(out)]}[case]
    if case == "out=symlink-to-dets":
        link.symlink_to(seq)
    if case == "out=hardlink-to-dets":
        os.link(seq, link)
    assert main(argv) == 2
    line = _one_error_line(capsys)
    assert "same file" in line and line.startswith("refimpl track: error:")
    assert seq.read_bytes() == before and not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["TUD-Campus"] + (["link.txt"] if "link" in case else []))


def test_an_output_that_is_a_directory_or_under_a_file_is_refused_before_the_run(seq, tmp_path, capsys):
    assert main(_track(seq, "--out", tmp_path)) == 2
    assert "is a directory" in _one_error_line(capsys)
    assert main(_track(seq, "--out", tmp_path / "r.txt", "--events", seq / "x.lp")) == 2  # det.txt is a file
    assert "not a directory" in _one_error_line(capsys)
    assert not (tmp_path / "r.txt").exists()


def test_a_missing_output_folder_is_created(seq, tmp_path):
    assert main(_track(seq, "--out", tmp_path / "a" / "b" / "r.txt")) == 0
    assert len(read_mot_results(tmp_path / "a" / "b" / "r.txt")) > 0


def test_a_symlinked_output_is_written_through_to_its_target(seq, tmp_path):
    target = tmp_path / "real.txt"
    target.write_text("old\n")
    link = tmp_path / "res.txt"
    link.symlink_to(target)
    assert main(_track(seq, "--out", link)) == 0
    assert link.is_symlink() and os.readlink(link) == str(target)
    assert len(read_mot_results(target)) > 0 and target.read_text() != "old\n"


def test_a_fifo_receives_the_output_and_stays_a_fifo(seq, tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    got = []
    reader = threading.Thread(target=lambda: got.append(open(fifo, "rb").read()))
    reader.start()
    assert main(_track(seq, "--out", fifo)) == 0
    reader.join(10)
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
    ref = tmp_path / "ref.txt"
    assert main(_track(seq, "--out", ref)) == 0
    assert got == [ref.read_bytes()] and got[0].count(b"\n") > 100


def test_dev_null_stays_a_device_node(seq):
    assert main(_track(seq, "--out", "/dev/null")) == 0
    assert stat.S_ISCHR(os.lstat("/dev/null").st_mode)
    assert os.stat("/dev/null").st_mode & 0o666 == 0o666


def test_an_existing_files_mode_is_kept(seq, tmp_path):
    out = tmp_path / "res.txt"
    out.write_text("secret\n")
    out.chmod(0o600)
    assert main(_track(seq, "--out", out)) == 0
    assert stat.S_IMODE(out.stat().st_mode) == 0o600 and out.read_text() != "secret\n"


@pytest.mark.parametrize("umask, mode", [(0o077, 0o600), (0o022, 0o644), (0o002, 0o664)])
def test_a_new_file_respects_the_umask(seq, tmp_path, umask, mode):
    # open() would create 0o666 & ~umask: 077 -> 600, 022 -> 644, 002 -> 664
    out = tmp_path / "res.txt"
    code = f"import os, sys; os.umask({umask}); from refimpl.cli import main; sys.exit(main(sys.argv[1:]))"
    subprocess.run([sys.executable, "-c", code, *_track(seq, "--out", out, "--events", tmp_path / "e.lp")],
                   cwd=REPO, check=True, capture_output=True)
    assert stat.S_IMODE(out.stat().st_mode) == mode


def test_out_dash_writes_standard_output(seq, tmp_path, capsys):
    ref = tmp_path / "ref.txt"
    assert main(_track(seq, "--out", ref)) == 0
    capsys.readouterr()
    assert main(_track(seq, "--out", "-")) == 0
    cap = capsys.readouterr()
    assert cap.out == ref.read_text() and "-> -" in cap.err
    assert main(_track(seq, "--out", "-", "--events", "-")) == 2
    assert "both write to standard output" in _one_error_line(capsys)


def test_outputs_of_one_command_land_together_or_not_at_all(tmp_path):
    a, b = tmp_path / "a.txt", tmp_path / "b.txt"
    a.write_text("old a\n")
    with pytest.raises(KeyboardInterrupt):
        with OutputSet() as outs:
            outs.write(a, "new a\n")
            outs.write(b, "new b\n")
            raise KeyboardInterrupt
    assert a.read_text() == "old a\n" and not b.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt"]  # no temporary file left
    with OutputSet() as outs:
        outs.write(a, "new a\n")
        outs.write(b, "new b\n")
        assert a.read_text() == "old a\n" and not b.exists()  # nothing lands before the commit
    assert (a.read_text(), b.read_text()) == ("new a\n", "new b\n")


def test_an_aborted_set_removes_the_folders_it_created(tmp_path):
    with pytest.raises(RuntimeError):
        with OutputSet() as outs:
            outs.write(tmp_path / "x" / "y" / "f.txt", "z")
            raise RuntimeError("boom")
    assert list(tmp_path.iterdir()) == []


def test_check_outputs_names_both_options():
    with pytest.raises(OutputError, match=r"--events \./a\.txt is the same file as --out a\.txt"):
        check_outputs({"--out": "a.txt", "--events": "./a.txt"})


def test_plot_refuses_its_scene_as_output_and_a_folder(tmp_path, capsys):
    scene = tmp_path / "s.json"
    scene.write_text("{}")
    assert main(["plot", str(scene), "--out", str(scene)]) == 2
    assert "same file" in _one_error_line(capsys) and scene.read_text() == "{}"
    assert main(["plot", str(scene), "--out", str(tmp_path)]) == 2
    assert "is a directory" in _one_error_line(capsys)


def test_bench_scale_writes_nothing_when_its_json_input_is_malformed(tmp_path, capsys):
    bad = tmp_path / "bad.json"
    bad.write_text('{"kind": "scale", "runs": [{"backend": 1}]}')
    md = tmp_path / "bench.md"
    assert main(["bench-scale", "--from-json", str(bad), "--out", str(md), "--quiet"]) == 2
    assert str(bad) in _one_error_line(capsys)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.json"]
    assert main(["bench-scale", "--from-json", str(bad), "--json", str(bad), "--out", "-"]) == 2
    assert "same file" in _one_error_line(capsys)


@pytest.mark.parametrize("given", ["new/", "new/.", "new//"])
def test_an_output_naming_a_missing_folder_is_refused_and_nothing_is_made(seq, tmp_path, capsys, given):
    # "new/" used to be written as a regular file named "new"
    out = str(tmp_path) + "/" + given
    assert main(_track(seq, "--out", out)) == 2
    line = _one_error_line(capsys)
    assert f"--out {out}: names a folder, not a file" in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["TUD-Campus"]  # no file "new", no folder either


def test_an_existing_folder_with_a_slash_is_a_directory_not_a_file(seq, tmp_path, capsys):
    assert main(_track(seq, "--out", str(tmp_path) + "/")) == 2
    assert "is a directory, not a file" in _one_error_line(capsys)


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="no /dev/full")
def test_a_full_device_is_named_in_one_line(seq, capsys):
    # /dev/full answers every write with ENOSPC: the staged output is copied into it at the end
    assert main(_track(seq, "--out", "/dev/full")) == 2
    assert _one_error_line(capsys) == "refimpl track: error: cannot write /dev/full: No space left on device"


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="no /dev/full")
def test_standard_output_on_a_full_device_is_named_in_one_line(seq):
    with open("/dev/full", "w") as full:
        proc = subprocess.run([sys.executable, "-m", "refimpl", *_track(seq, "--out", "-")], cwd=REPO,
                              stdout=full, stderr=subprocess.PIPE, text=True, timeout=120)
    assert proc.returncode == 2
    assert proc.stderr.splitlines()[-1] == "refimpl track: error: cannot write standard output: No space left on device"
    assert "Traceback" not in proc.stderr


@pytest.fixture
def tiny_disk(tmp_path):
    """A 4 KiB tmpfs (root only; skipped where mounting is not allowed)."""
    mnt = tmp_path / "tiny"
    mnt.mkdir()
    if os.geteuid() != 0 or shutil.which("mount") is None:
        pytest.skip("mounting a tmpfs needs root")
    made = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=4k", "tmpfs", str(mnt)], capture_output=True)
    if made.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {made.stderr.decode().strip()}")
    try:
        yield mnt
    finally:
        subprocess.run(["umount", str(mnt)], check=True)


def test_a_full_disk_names_the_output_and_leaves_nothing(seq, tiny_disk, tmp_path, capsys):
    # the demo's results (about 12 KB with SORT) do not fit in 4 KiB: ENOSPC while the streamed
    # lines are written or flushed; the error names the output and no temporary file is left
    ref = tmp_path / "ref.txt"
    assert main(_track(seq, "--out", ref)) == 0 and ref.stat().st_size > 4096
    capsys.readouterr()
    out = tiny_disk / "r.txt"
    assert main(_track(seq, "--out", out)) == 2
    assert _one_error_line(capsys) == f"refimpl track: error: cannot write {out}: No space left on device"
    assert list(tiny_disk.iterdir()) == []


def test_an_os_error_on_commit_names_the_output(tmp_path, monkeypatch):
    # a fake I/O error from fsync (the commit's flush to disk): the message names the output, the
    # target keeps its old content and the temporary file is removed
    import errno
    target = tmp_path / "a.txt"
    target.write_text("old\n")

    def fsync(fd):
        raise OSError(errno.EIO, os.strerror(errno.EIO))
    monkeypatch.setattr(os, "fsync", fsync)
    with pytest.raises(OutputError, match=f"^cannot write {target}: Input/output error$"):
        with OutputSet() as outs:
            outs.open(target).write("new\n")
    assert target.read_text() == "old\n" and sorted(p.name for p in tmp_path.iterdir()) == ["a.txt"]
    with pytest.raises(OutputError, match=f"^cannot write {tmp_path / 'b.txt'}: Input/output error$"):
        with OutputSet() as outs:
            outs.write(tmp_path / "b.txt", "whole\n")  # write() syncs at once
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt"]


def test_a_write_error_while_streaming_names_the_output(tmp_path):
    # the handle a writer gets wraps the file: an OS error of its write() names the output
    import errno

    class Full:
        closed = False

        def write(self, data):
            raise OSError(errno.EDQUOT, os.strerror(errno.EDQUOT))

    from refimpl.io.outputs import _Handle
    with pytest.raises(OutputError, match=f"^cannot write out.txt: {os.strerror(errno.EDQUOT)}$"):
        _Handle(Full(), "out.txt").write("x")


def test_a_write_error_is_an_os_error_too_and_pickles():
    import errno
    import pickle

    from refimpl.io.outputs import OutputWriteError
    exc = OutputWriteError("out.txt", OSError(errno.ENOSPC, os.strerror(errno.ENOSPC)))
    assert isinstance(exc, OSError) and isinstance(exc, OutputError)
    assert (exc.errno, exc.filename, str(exc)) == (errno.ENOSPC, "out.txt", "cannot write out.txt: No space left on device")
    back = pickle.loads(pickle.dumps(exc))
    assert (type(back), back.errno, str(back)) == (OutputWriteError, errno.ENOSPC, str(exc))
