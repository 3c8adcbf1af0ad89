"""One writer per output (rcsim/analysis/engine/output.py ``output_lock``), with real processes.

Issue 17, defect 3: `rcsim campaign run spec --out D` and, seconds later, the same with
`--resume` both ran and both exited 0, the second re-flying runs.  The claim: the second
writer is refused with one line naming the first (its pid and command), exit 2, and the
first finishes its campaign undisturbed.
"""

import os
import signal
import subprocess
import sys
import threading
import time

import pandas as pd
import pytest

from rcsim.analysis.engine.output import OutputLocked, output_lock

SPEC = """
seed = 5
runs_per_case = 6
chunk_size = 2
[scenario]
cases = [13, 22]
duration_s = 120.0
[controller]
name = "phase-plane"
[output]
histories = "none"
plots = false
"""


def _rcsim(*args) -> list[str]:
    return [sys.executable, "-m", "rcsim", *args]


@pytest.mark.slow
def test_a_second_campaign_writer_is_refused_and_the_first_finishes(tmp_path):
    spec = tmp_path / "spec.toml"
    spec.write_text(SPEC)
    out = tmp_path / "D"
    first = subprocess.Popen(
        _rcsim("campaign", "run", str(spec), "--out", str(out), "--no-progress"),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        lock = tmp_path / ".D.rcsim-lock"
        deadline = time.monotonic() + 120
        while not (lock.exists() and lock.read_text()) and time.monotonic() < deadline:
            assert first.poll() is None, first.stderr.read()
            time.sleep(0.01)
        second = subprocess.run(
            _rcsim("campaign", "run", str(spec), "--out", str(out), "--resume", "--no-progress"),
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert second.returncode == 2, second.stderr
        lines = second.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("rcsim: error: --out"), second.stderr
        assert f"pid {first.pid}, rcsim campaign run" in lines[0]
        assert first.wait(timeout=300) == 0, first.stderr.read()
    finally:
        if first.poll() is None:
            first.send_signal(signal.SIGKILL)
            first.wait()
    runs = pd.read_parquet(out / "runs.parquet")
    assert sorted(runs["run_id"]) == list(range(12))  # every run once: nothing re-flown
    assert not lock.exists()  # released and removed


def test_the_lock_names_its_holder_and_is_free_after_the_block(tmp_path):
    target = tmp_path / "out"
    probe = (
        "import sys\n"
        "from rcsim.analysis.engine.output import OutputLocked, output_lock\n"
        "try:\n"
        f"    with output_lock({str(target)!r}, 'other'):\n"
        "        print('GOT IT')\n"
        "except OutputLocked as exc:\n"
        "    print('REFUSED', exc)\n"
    )
    with output_lock(target, "maneuver"):
        held = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True)
        assert held.stdout.startswith("REFUSED"), held.stdout + held.stderr
        assert f"pid {os.getpid()}, rcsim maneuver" in held.stdout
        # Within one process: the same thread re-enters its own lock (a command claims its
        # output before the work, then writes it), another thread is refused.
        with output_lock(target, "again"):
            pass
        assert (tmp_path / ".out.rcsim-lock").exists()  # still held by the outer block
        refused = []

        def other_thread():
            try:
                with output_lock(target, "again"):
                    pass
            except OutputLocked as exc:
                refused.append(exc)

        thread = threading.Thread(target=other_thread)
        thread.start()
        thread.join()
        assert len(refused) == 1
    free = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True)
    assert free.stdout.startswith("GOT IT"), free.stdout + free.stderr
    assert list(tmp_path.iterdir()) == []  # no lock file, no directory left behind


# A directory mounted at a second path (``mount --bind D B``): the lock file beside ``B`` is
# another file than the one beside ``D``, so the path lock alone let a second `campaign run
# --resume` through ``B`` fly beside the first.  The directory is also locked by its identity
# (device and inode).  The first test needs no mount: with symbolic links left unresolved a
# link is, to the path lock, exactly such a second path.


def _second_path_unseen(monkeypatch):
    """Path locks stop resolving symbolic links: a link becomes a second path to the same
    directory that its lock file cannot tell, as a bind mount is."""
    from rcsim.analysis.engine import locks

    monkeypatch.setattr(
        locks, "real_path", lambda p: __import__("pathlib").Path(os.path.abspath(p))
    )


def test_a_directory_reached_by_a_second_path_is_locked_by_its_identity(tmp_path, monkeypatch):
    from rcsim.analysis.engine.output_records import write_marker

    _second_path_unseen(monkeypatch)
    existing = tmp_path / "D"
    existing.mkdir()
    (tmp_path / "B").symlink_to(existing)
    with output_lock(existing, "campaign run"):
        with pytest.raises(OutputLocked, match="through another path") as refused:
            with output_lock(tmp_path / "B", "campaign run"):
                pass
        assert f"pid {os.getpid()}" in str(refused.value)  # the holder, from /proc/locks
    # A directory made after its lock was taken (a new campaign): locked by its identity
    # from its marker on, the first thing its writer puts there.
    new = tmp_path / "N"
    (tmp_path / "M").symlink_to(new)
    with output_lock(new, "campaign run"):
        new.mkdir()
        with output_lock(tmp_path / "M", "campaign run"):
            pass  # not yet claimed: the writer has not written its marker
        write_marker(new, "campaign run")
        with pytest.raises(OutputLocked, match="through another path"):
            with output_lock(tmp_path / "M", "campaign run"):
                pass
    with output_lock(tmp_path / "M", "campaign run"):
        pass  # released with the path lock
    assert sorted(p.name for p in tmp_path.iterdir()) == ["B", "D", "M", "N"]  # no lock file


@pytest.fixture
def bind_mount(tmp_path):
    """``tmp_path/D`` mounted at ``tmp_path/B`` (skipped where mounting is refused)."""
    source, second = tmp_path / "D", tmp_path / "B"
    source.mkdir()
    second.mkdir()
    try:
        done = subprocess.run(
            ["mount", "--bind", str(source), str(second)], capture_output=True, text=True
        )
    except FileNotFoundError:
        pytest.skip("no mount command")
    if done.returncode != 0:
        pytest.skip(f"mount --bind refused: {done.stderr.strip()}")
    yield source, second
    if subprocess.run(["umount", str(second)], capture_output=True).returncode != 0:
        subprocess.run(["umount", "-l", str(second)], check=True)  # still busy: lazily


def test_a_bind_mounted_campaign_directory_takes_no_second_writer(bind_mount):
    source, second = bind_mount
    assert os.stat(source).st_ino == os.stat(second).st_ino  # one directory, two paths
    probe = (
        "from rcsim.analysis.engine.output import OutputLocked, output_lock\n"
        "try:\n"
        f"    with output_lock({str(second)!r}, 'campaign run'):\n"
        "        print('GOT IT')\n"
        "except OutputLocked as exc:\n"
        "    print('REFUSED', exc)\n"
    )
    with output_lock(source, "campaign run"):
        held = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True)
    assert held.stdout.startswith("REFUSED"), held.stdout + held.stderr
    assert "through another path" in held.stdout and f"pid {os.getpid()}" in held.stdout
    free = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True)
    assert free.stdout.startswith("GOT IT"), free.stdout + free.stderr
