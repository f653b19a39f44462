"""Nothing lost: atomic writes, and an interrupted run (Ctrl-C or killed) resumes to identical results.

``reconstruct`` runs as a subprocess with ``--workers 1`` on the 4-frame S3
phantom of ``test_robustness``; it is interrupted (SIGINT, or SIGKILL) once
some frame files exist, the same command runs again (in-process, to save the
interpreter's start-up) and every result table is compared byte for byte
with an uninterrupted run.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

from tendrilkit import cli
from tendrilkit.pipeline import RESULT_FILES
from tests.test_robustness import N_FRAMES, phantom_experiment

ROOT = Path(__file__).resolve().parents[1]


def _command(exp: Path, out: Path) -> list[str]:
    return [sys.executable, "-m", "tendrilkit", "reconstruct", str(exp), "--out", str(out), "--workers", "1", "--quiet"]


def _frame_files(out: Path) -> list[Path]:
    return sorted((out / "frames").glob("frame_*.json")) if (out / "frames").is_dir() else []


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The phantom and an uninterrupted run of it (in-process: the same code as the subprocess)."""
    exp = phantom_experiment(tmp_path_factory)
    out = tmp_path_factory.mktemp("resume_reference") / "out"
    assert cli.main(["reconstruct", str(exp), "--out", str(out), "--workers", "1", "--quiet"]) == 0
    return exp, out


@pytest.mark.slow
@pytest.mark.parametrize("sig,after", [(signal.SIGINT, 1), (signal.SIGTERM, 1), (signal.SIGKILL, 2)],
                         ids=["ctrl-c", "sigterm", "killed"])
def test_interrupt_and_resume(reference, tmp_path, capsys, sig, after):
    exp, ref = reference
    out = tmp_path / "out"
    env = {**os.environ, "TENDRILKIT_PROGRESS": "0"}
    # Ctrl-C as in a terminal: a test suite started in the background (`cmd &` in a script) inherits SIGINT
    # ignored, and Python then ignores it too; the run would finish and exit 0
    proc = subprocess.Popen(_command(exp, out), cwd=ROOT, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        deadline = time.monotonic() + 120
        while len(_frame_files(out)) < after and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.01)
        assert proc.poll() is None, f"the run ended before it could be interrupted: {proc.communicate()}"
        proc.send_signal(sig)
        stdout, stderr = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    kept = _frame_files(out)
    if sig == signal.SIGINT:
        assert proc.returncode == 130, stderr
        assert stderr.strip().splitlines()[-1].startswith("tendrilkit: interrupted; finished frames are kept")
        assert "Traceback" not in stderr
    elif sig == signal.SIGTERM:  # as Ctrl-C: one line, finished frames kept, its own code
        assert proc.returncode == 143, stderr
        assert stderr.strip().splitlines() == [stderr.strip().splitlines()[-1]], stderr
        assert stderr.strip().startswith("tendrilkit: terminated (SIGTERM); finished frames are kept")
    else:
        assert proc.returncode == -signal.SIGKILL
    assert after <= len(kept) < N_FRAMES, "the interrupt came too late to test resuming"
    for p in kept:  # every frame file on disk is whole (atomic writes)
        d = json.loads(p.read_text())
        assert d["result"]["status"] == "ok" and d["fingerprint"]
    assert not (out / "curves.csv").exists()  # the tables come only at the end
    stamps = {p.name: p.stat().st_mtime_ns for p in kept}

    # the same command again (in-process: the interpreter and compiled kernels are already warm)
    code = cli.main(_command(exp, out)[3:])
    stdout, stderr = capsys.readouterr()
    assert code == 0, stderr
    assert stdout.strip().splitlines()[-1] == f"{N_FRAMES} frames: {N_FRAMES} ok, 0 doubtful, 0 failed"
    # the finished frames were not recomputed (unless tendrilkit's code changed in between: a new fingerprint)
    assert {p.name: p.stat().st_mtime_ns for p in kept} == stamps
    assert len(_frame_files(out)) == N_FRAMES
    for name in RESULT_FILES:
        assert (out / name).read_bytes() == (ref / name).read_bytes(), name
    assert (out / "cameras.json").read_bytes() == (ref / "cameras.json").read_bytes()
    # no temporary file is left behind except, after SIGKILL, at most the one being written
    leftovers = [p.name for p in out.rglob(".*.tmp")]
    assert len(leftovers) <= (1 if sig == signal.SIGKILL else 0), leftovers


@pytest.mark.slow
def test_frame_file_of_another_run_is_recomputed(reference, tmp_path):
    """A stale frame file (other fingerprint), an edited one, one copied over another frame's,
    one with ``"reprojection": null`` or a truncated one is never reused: it is recomputed."""
    exp, ref = reference
    out = tmp_path / "out"
    import shutil

    shutil.copytree(ref, out)
    frames = out / "frames"
    f1, f2, f3 = (frames / f"frame_00000{i}.json" for i in (1, 2, 3))
    original1 = f1.read_bytes()
    d = json.loads(original1)  # edited by hand, fingerprint kept
    d["result"]["points_mm"] = [[0.0, 0.0, 0.0]] * len(d["result"]["points_mm"])
    f1.write_text(json.dumps(d))
    f2.write_bytes(original1)  # frame 1's file copied over frame 2's
    d = json.loads(f3.read_text())
    d["result"]["reprojection"] = None
    f3.write_text(json.dumps(d))
    f0 = frames / "frame_000000.json"
    stamp0 = f0.stat().st_mtime_ns
    assert cli.main(["reconstruct", str(exp), "--out", str(out), "--workers", "1", "--quiet"]) == 0
    for name in RESULT_FILES:
        assert (out / name).read_bytes() == (ref / name).read_bytes(), name
    assert f0.stat().st_mtime_ns == stamp0  # the intact frame was reused
    for f in (f1, f2, f3):
        assert f.read_bytes() == (ref / "frames" / f.name).read_bytes()  # recomputed to the same record
    # a stale fingerprint or a truncated file: recomputed too
    d = json.loads(f1.read_text())
    d["fingerprint"] = "0" * 64
    f1.write_text(json.dumps(d))
    f2.write_text('{"fingerprint": "trunc')
    assert cli.main(["reconstruct", str(exp), "--out", str(out), "--workers", "1", "--quiet"]) == 0
    for name in RESULT_FILES:
        assert (out / name).read_bytes() == (ref / name).read_bytes(), name


@pytest.mark.slow
def test_disk_full_mid_run_exits_74_and_keeps_the_finished_frames(reference, tmp_path, capsys, monkeypatch):
    """The third frame file hits a full disk: one line, exit code 74, two frames kept; the rerun completes identically."""
    import errno

    from tendrilkit import io

    exp, ref = reference
    out = tmp_path / "out"
    real = io.write_frame_record
    calls = []

    def filling(path, *args):
        calls.append(path)
        if len(calls) >= 3:
            with io.atomic_path(path):
                raise OSError(errno.ENOSPC, "No space left on device")
        real(path, *args)

    monkeypatch.setattr(io, "write_frame_record", filling)
    code = cli.main(_command(exp, out)[3:])
    stdout, stderr = capsys.readouterr()
    assert code == 74, stderr
    lines = stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in stderr
    assert "frame_000002.json: cannot write (No space left on device)" in lines[0] and "finished frames are kept" in lines[0]
    assert [p.name for p in _frame_files(out)] == ["frame_000000.json", "frame_000001.json"]
    assert not list(out.rglob(".*.tmp"))
    monkeypatch.setattr(io, "write_frame_record", real)  # space freed
    assert cli.main(_command(exp, out)[3:]) == 0
    for name in RESULT_FILES:
        assert (out / name).read_bytes() == (ref / name).read_bytes(), name


@pytest.mark.slow
def test_video_replaced_by_a_file_of_the_same_size_is_not_reused(reference, tmp_path):
    """Same size and modification time, other content: the calibration and every frame are redone."""
    exp, ref = reference
    import shutil

    work = tmp_path / "exp"
    shutil.copytree(exp.parent, work)
    exp2 = work / exp.name
    out = tmp_path / "out"
    assert cli.main(_command(exp2, out)[3:] + ["--workers", "1"]) == 0
    first = {p.name: json.loads(p.read_text())["fingerprint"] for p in _frame_files(out)}
    stamp = (out / "frames" / "calibration_stamp.json").read_text()
    video = work / "view2.mp4"
    st = video.stat()
    data = bytearray(video.read_bytes())
    i = len(data) // 2
    data[i:i + 64] = bytes(64)  # a few bytes of one frame's compressed data
    video.write_bytes(bytes(data))
    os.utime(video, ns=(st.st_atime_ns, st.st_mtime_ns))
    assert video.stat().st_size == st.st_size and video.stat().st_mtime_ns == st.st_mtime_ns
    cli.main(_command(exp2, out)[3:])
    assert (out / "frames" / "calibration_stamp.json").read_text() != stamp
    after = {p.name: json.loads(p.read_text())["fingerprint"] for p in _frame_files(out)}
    assert after.keys() == first.keys() and all(after[k] != first[k] for k in first)


def test_atomic_write_keeps_the_old_file_when_writing_fails(tmp_path, monkeypatch):
    from tendrilkit.io import write_csv

    target = tmp_path / "table.csv"
    write_csv(pd.DataFrame({"a": [1.0]}), target)
    before = target.read_bytes()

    def broken(self, path, **kw):
        Path(path).write_text("a\n1.0\n2.0")  # half a table, then the disk fails
        raise OSError("disk full")

    monkeypatch.setattr(pd.DataFrame, "to_csv", broken)
    with pytest.raises(OSError):
        write_csv(pd.DataFrame({"a": [1.0, 2.0, 3.0]}), target)
    assert target.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["table.csv"]
