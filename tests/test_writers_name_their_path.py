"""Every writer names its file when the disk is full, and a closed stdout is no error
(issue 47, item 6)."""

from __future__ import annotations

import errno
import io
import os
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import run_cli
from test_cli import one_line_error

from voiopt.core import instance
from voiopt.networks.generate import case_study
from voiopt.runtime import files

ROOT = Path(__file__).resolve().parents[1]


class _Full(io.StringIO):
    def write(self, s):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


@pytest.fixture
def full_disk(monkeypatch):
    """Every file opened for writing by files takes no byte: write() raises ENOSPC."""
    def fdopen(fd, *a, **k):
        os.close(fd)
        return _Full()
    monkeypatch.setattr(os, "fdopen", fdopen)


def _binary(path):
    with files.atomic_write(path, binary=True) as f:  # the figures' writer
        f.write(b"png")


@pytest.mark.parametrize("write", [
    lambda p: files.write_json_atomic(p, {"a": 1}),
    lambda p: files.write_csv(p, [{"a": 1}], ["a"]),
    lambda p: instance.save(case_study(), p),
    _binary,
])
def test_a_full_disk_names_the_file_and_leaves_nothing(tmp_path, full_disk, write):
    path = tmp_path / "out.json"
    with pytest.raises(OSError) as e:
        write(path)
    assert e.value.errno == errno.ENOSPC and str(path) in str(e.value), str(e.value)
    assert list(tmp_path.iterdir()) == []  # no temporary file left


def test_the_command_line_names_the_file_on_a_full_disk(tmp_path, capsys, full_disk):
    out = tmp_path / "r.json"
    code, _, err = run_cli(capsys, "solve", str(ROOT / "instances" / "case-study.json"), "--method", "greedy",
                       "--quiet", "-o", str(out))
    line = one_line_error(err)
    assert code == 1 and f"cannot write {out}: No space left on device" in line, line


def test_a_closed_pipe_ends_in_silence_and_status_0():
    """voiopt generate | head -1: the instance is larger than a pipe's buffer."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen([sys.executable, "-m", "voiopt", "generate", "--sensors", "1000", "--width", "30",
                             "--height", "30"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    assert proc.stdout.readline().strip() == b"{"
    proc.stdout.close()
    err = proc.stderr.read()
    assert proc.wait() == 0 and err == b"", err
