"""Outputs survive faults: a run's files are committed as one set (written beside the output
folder, swapped in at once), so a fault leaves the old set or the new one, never a mix, and
no temporary folder behind."""
import errno
import json
import os
import pathlib
import signal
import subprocess
import threading

import pytest

import linkwright.output as output
from linkwright import atomic
from linkwright.cli import main
from linkwright.examples import folder as examples_folder
from linkwright.interrupt import Interrupted
from linkwright.output import MARKER, OutputFolderError, Outputs, OutputWriteError

from .util import command, env, temporaries, tree

EX = examples_folder()


def run(args, capsys):
    code = main([str(a) for a in args])
    out = capsys.readouterr()
    return code, out.out, out.err


def commit(folder, files, cmd="test"):
    o = Outputs(folder, cmd)
    for name, text in files.items():
        o.add(name, text)
    return o.commit()


def failing_write(monkeypatch, at, exc):
    """Make the ``at``-th file write raise ``exc``."""
    real = pathlib.Path.write_bytes
    calls = []

    def write(self, data):
        calls.append(self)
        if len(calls) == at:
            raise exc
        return real(self, data)
    monkeypatch.setattr(pathlib.Path, "write_bytes", write)


def test_a_commit_replaces_the_previous_set_whole(tmp_path):
    commit(tmp_path / "o", {"a.txt": "1", "b.txt": "1"})
    written = commit(tmp_path / "o", {"a.txt": "2", "c/d.txt": "2"})
    t = tree(tmp_path / "o")
    assert set(t) == {"a.txt", "c", "c/d.txt", MARKER}
    assert t["a.txt"] == b"2" and json.loads(t[MARKER])["entries"] == ["a.txt", "c"]
    assert written == [tmp_path / "o" / "a.txt", tmp_path / "o" / "c/d.txt"]
    assert temporaries(tmp_path) == []


def test_folders_linkwright_did_not_write_are_refused_untouched(tmp_path):
    user = tmp_path / "user"
    user.mkdir()
    (user / "notes.txt").write_text("mine")
    with pytest.raises(OutputFolderError, match="did not write"):
        commit(user, {"a.txt": "x"})
    assert tree(user) == {"notes.txt": b"mine"}
    commit(tmp_path / "o", {"a.txt": "1"})
    (tmp_path / "o" / "notes.txt").write_text("mine")
    with pytest.raises(OutputFolderError, match="notes.txt"):
        commit(tmp_path / "o", {"a.txt": "2"})
    assert (tmp_path / "o" / "a.txt").read_text() == "1"
    (tmp_path / "file").write_text("x")
    with pytest.raises(OutputFolderError, match="not a folder"):
        commit(tmp_path / "file", {"a.txt": "2"})
    (tmp_path / "empty").mkdir()
    commit(tmp_path / "empty", {"a.txt": "3"})
    assert (tmp_path / "empty" / "a.txt").read_text() == "3"
    assert temporaries(tmp_path) == []


def test_the_current_folder_is_never_replaced(tmp_path, monkeypatch):
    (tmp_path / "cwd").mkdir()
    monkeypatch.chdir(tmp_path / "cwd")
    for target in (".", tmp_path):
        with pytest.raises(OutputFolderError, match="current folder"):
            commit(target, {"a.txt": "x"})
    assert tree(tmp_path) == {"cwd": None}


def test_a_failed_run_into_a_new_folder_leaves_no_folder(tmp_path, monkeypatch):
    failing_write(monkeypatch, 2, OSError(errno.ENOSPC, "No space left on device"))
    with pytest.raises(OutputWriteError, match="No space left on device"):
        commit(tmp_path / "a" / "b" / "c", {"x.txt": "1", "y.txt": "2"})
    assert list(tmp_path.iterdir()) == []


def test_disk_full_exits_1_and_keeps_the_old_set(tmp_path, capsys, monkeypatch):
    out = tmp_path / "out"
    assert run(["synth", EX / "seed001_rrr.toml", "-o", out, "--quiet"], capsys)[0] == 0
    before = tree(out)
    failing_write(monkeypatch, 3, OSError(errno.ENOSPC, "No space left on device"))
    code, _, err = run(["synth", EX / "seed001_rrr.toml", "-o", out, "--quiet"], capsys)
    assert code == 1 and "No space left on device" in err and "nothing was changed" in err
    assert tree(out) == before and temporaries(tmp_path) == []


def test_a_read_only_output_folder_exits_2_before_running(tmp_path, capsys, monkeypatch):
    out = tmp_path / "out"
    commit(out, {"old.txt": "old"})
    before = tree(out)
    real = os.access

    def access(path, mode, *a, **k):            # root writes anywhere: pretend
        if mode & os.W_OK and (pathlib.Path(path) == out or "dir_fd" in k):
            return False
        return real(path, mode, *a, **k)
    monkeypatch.setattr(os, "access", access)
    code, _, err = run(["synth", EX / "seed001_rrr.toml", "-o", out, "--quiet"], capsys)
    assert code == 2 and "read-only" in err and "nothing was changed" in err
    assert tree(out) == before and temporaries(tmp_path) == []


@pytest.mark.skipif(os.name != "posix", reason="POSIX permissions")
def test_a_read_only_parent_folder_exits_2(tmp_path, capsys, monkeypatch):
    ro = tmp_path / "ro"
    ro.mkdir()
    os.chmod(ro, 0o555)
    if os.geteuid() == 0:                       # root writes anywhere: the refusal is simulated
        real_access, real_mkdir = os.access, os.mkdir

        def access(path, mode, *a, **k):
            if mode & os.W_OK and pathlib.Path(path) == ro:
                return False
            return real_access(path, mode, *a, **k)

        def mkdir(path, *a, **k):
            if pathlib.Path(path).parent == ro:
                raise PermissionError(13, "Permission denied", str(path))
            return real_mkdir(path, *a, **k)
        monkeypatch.setattr(os, "access", access)
        monkeypatch.setattr(os, "mkdir", mkdir)
    try:
        code, _, err = run(["synth", EX / "seed001_rrr.toml", "-o", tmp_path / "ro" / "out"],
                           capsys)
        assert code == 2 and "nothing was changed" in err
        assert list((tmp_path / "ro").iterdir()) == []
    finally:
        os.chmod(tmp_path / "ro", 0o755)


def test_a_directory_in_place_of_an_output_file(tmp_path, capsys):
    out, ref = tmp_path / "out", tmp_path / "ref"
    assert run(["stiffness", EX / "hexapod.toml", "-o", out, "--quiet"], capsys)[0] == 0
    assert (out / "map.csv").exists()
    (out / "report.md").unlink()
    (out / "report.md").mkdir()                      # a folder where a report file was
    study = tmp_path / "hexapod.toml"                # a different study: no map, other legs
    text = (EX / "hexapod.toml").read_text()
    study.write_text(text[:text.index("[map]")].replace("leg_stiffness = 2.0e7",
                                                         "leg_stiffness = 3.0e7"))
    code, _, err = run(["stiffness", study, "-o", out, "--quiet"], capsys)
    assert code == 0, err
    assert run(["stiffness", study, "-o", ref, "--quiet"], capsys)[0] == 0
    assert tree(out) == tree(ref)                    # exactly the new set, nothing old
    assert temporaries(tmp_path) == []


@pytest.mark.parametrize("exchange", [True, False], ids=["renameat2", "two-renames"])
def test_concurrent_commits_leave_one_whole_set(tmp_path, monkeypatch, exchange):
    if not exchange:
        monkeypatch.setattr(atomic, "_renameat2_fn", False)
    target, errors = tmp_path / "out", []

    def worker(k):
        try:
            for i in range(15):
                commit(target, {f"only{k}.txt": f"{k}.{i}", "common.txt": f"{k}.{i}",
                                f"sub{k}/x.txt": f"{k}.{i}"}, f"run{k}")
        except BaseException as e:  # noqa: BLE001 - reported below
            errors.append(e)
    threads = [threading.Thread(target=worker, args=(k,)) for k in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
    t = tree(target)
    k, i = t["common.txt"].decode().split(".")
    assert set(t) == {f"only{k}.txt", "common.txt", f"sub{k}", f"sub{k}/x.txt", MARKER}
    assert {t[n] for n in (f"only{k}.txt", f"sub{k}/x.txt")} == {f"{k}.{i}".encode()}
    assert temporaries(tmp_path) == []


def test_two_runs_into_one_folder_leave_one_whole_set(tmp_path):
    out = tmp_path / "out"
    runs = {"synth": ("seed001_rrr.toml", "variants.csv"),
            "stiffness": ("hexapod.toml", "stiffness.csv")}
    procs = [subprocess.Popen(command(cmd, EX / study, "-o", out, "--quiet"), cwd=tmp_path,
                              env=env(), stderr=subprocess.PIPE, text=True)
             for cmd, (study, _) in runs.items()]
    results = [(p.wait(timeout=300), p.stderr.read()) for p in procs]
    for p in procs:
        p.stderr.close()
    assert [r[0] for r in results] == [0, 0], results
    t = tree(out)
    marker = json.loads(t[MARKER])
    assert set(t) == set(marker["entries"]) | {MARKER}
    mine, = [f for c, (_, f) in runs.items() if c == marker["command"]]
    other, = [f for c, (_, f) in runs.items() if c != marker["command"]]
    assert mine in t and other not in t
    assert temporaries(tmp_path) == []


def test_an_interrupt_while_writing_keeps_the_old_set(tmp_path, capsys, monkeypatch):
    out = tmp_path / "out"
    assert run(["synth", EX / "seed001_rrr.toml", "-o", out, "--quiet"], capsys)[0] == 0
    before = tree(out)
    failing_write(monkeypatch, 2, Interrupted(signal.SIGTERM))
    code, _, err = run(["synth", EX / "seed001_rrr.toml", "-o", out, "--quiet"], capsys)
    assert code == 143
    assert "interrupted by SIGTERM" in err and "nothing was written" in err
    assert tree(out) == before and temporaries(tmp_path) == []


def test_a_signal_during_the_swap_is_held_until_the_set_is_in(tmp_path, capsys, monkeypatch):
    out = tmp_path / "out"
    real = output.swap_in

    def swap(*a, **k):
        os.kill(os.getpid(), signal.SIGINT)          # arrives mid-swap: held, then delivered
        real(*a, **k)
    monkeypatch.setattr(output, "swap_in", swap)
    code, _, err = run(["synth", EX / "seed001_rrr.toml", "-o", out, "--quiet"], capsys)
    assert code == 130 and "interrupted by SIGINT" in err
    assert f"the outputs were written to {out}" in err
    assert {"variants.csv", "report.md", "report.html", MARKER} <= set(tree(out))
    assert temporaries(tmp_path) == []


def test_examples_copies_into_a_new_folder_only(tmp_path, capsys):
    code, out, _ = run(["examples", "-o", tmp_path / "studies"], capsys)
    assert code == 0 and "seed001_rrr" in out
    names = set(tree(tmp_path / "studies"))
    assert {"seed001_rrr.toml", "hexapod.toml", "crane.py"} <= names
    assert MARKER not in names and "__init__.py" not in names
    (tmp_path / "studies" / "mine.toml").write_text("# my study")
    code, _, err = run(["examples", "-o", tmp_path / "studies"], capsys)
    assert code == 2 and "not empty" in err
    assert (tmp_path / "studies" / "mine.toml").read_text() == "# my study"
