"""What --overwrite may remove, where an output may go, and one lock per real path (issue 31).

Oracle: issue 31's "What to build" 1-3: ``--overwrite`` removes only the files listed in the
earlier run's own record of outputs and refuses a directory holding anything else; no output
inside another command's output directory or over the command's own input, ``--overwrite``
or not; one lock per real directory (symbolic links resolved), taken before any work.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from rcsim.analysis.engine.locks import claim_scope, lock_file, output_lock
from rcsim.analysis.engine.output import MARKER, atomic_dir, check_out_dir
from rcsim.analysis.engine.output_places import refuse_nested, writing_inside
from rcsim.analysis.engine.output_records import (
    read_record,
    remove_listed,
    unlisted_entry,
    write_marker,
)
from rcsim.models.errors import InputError


def _write(out, command="maneuver", *, overwrite=False, names=("a.csv", "plots/p.png")):
    with atomic_dir(out, command, overwrite=overwrite) as tmp:
        for name in names:
            (tmp / name).parent.mkdir(parents=True, exist_ok=True)
            (tmp / name).write_text(name)


def test_the_record_lists_what_the_command_wrote(tmp_path):
    out = tmp_path / "m"
    _write(out)
    record = read_record(out)
    assert record is not None
    assert record["files"] == ["a.csv", "plots/p.png"] and record["dirs"] == ["plots"]
    assert (out / MARKER).read_text().splitlines()[0] == "written by rcsim maneuver"


def test_overwrite_replaces_a_directory_holding_only_what_it_lists(tmp_path):
    out = tmp_path / "m"
    _write(out)
    (out / "a.csv").unlink()  # a listed file the user removed: no obstacle
    _write(out, overwrite=True, names=("b.csv",))
    assert sorted(p.name for p in out.iterdir()) == [MARKER, "b.csv"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m"]  # nothing aside, no lock file


@pytest.mark.parametrize("extra", ["notes.txt", "plots/mine.png", "sub/"])
def test_overwrite_refuses_anything_the_record_does_not_list(tmp_path, extra):
    out = tmp_path / "m"
    _write(out)
    if extra.endswith("/"):
        (out / extra).mkdir()
    else:
        (out / extra).write_text("mine")
    before = sorted(str(p.relative_to(out)) for p in out.rglob("*"))
    with pytest.raises(InputError) as err:
        _write(out, overwrite=True)
    assert extra.rstrip("/") in str(err.value) and "does not list" in str(err.value)
    assert sorted(str(p.relative_to(out)) for p in out.rglob("*")) == before


def test_a_marker_that_only_claims_proves_nothing(tmp_path):
    # Issue 31: a campaign's files under a marker naming maneuver (no record of outputs).
    out = tmp_path / "c"
    out.mkdir()
    (out / MARKER).write_text("written by rcsim maneuver\n")
    (out / "runs.parquet").write_text("PAR1")
    with pytest.raises(InputError, match="lists no outputs"):
        check_out_dir(out, "maneuver", overwrite=True)
    assert (out / "runs.parquet").exists()


def test_removal_never_leaves_the_directory_nor_touches_unlisted_files(tmp_path):
    out = tmp_path / "m"
    _write(out)
    (tmp_path / "keep.txt").write_text("mine")
    (out / "extra.txt").write_text("mine")
    marker = (out / MARKER).read_text().splitlines()
    record = json.loads(marker[1])
    record["files"] += ["../keep.txt", "/etc/hostname", "plots/../../keep.txt"]
    (out / MARKER).write_text(f"{marker[0]}\n{json.dumps(record)}\n")
    left = remove_listed(out)
    assert left == ["extra.txt"]  # listed files gone, the unlisted one and its folder kept
    assert (out / "extra.txt").read_text() == "mine" and (tmp_path / "keep.txt").exists()
    assert not (out / "a.csv").exists() and not (out / "plots").exists()


def test_unlisted_entry_names_a_symlink(tmp_path):
    out = tmp_path / "m"
    _write(out)
    (out / "link").symlink_to(tmp_path)
    assert "link" in unlisted_entry(out)


def test_outputs_do_not_nest_except_where_a_command_writes_its_own(tmp_path):
    campaign = tmp_path / "C"
    campaign.mkdir()
    write_marker(campaign, "campaign run")
    with pytest.raises(InputError, match="inside a campaign directory"):
        refuse_nested(campaign / "histories", "maneuver")
    with pytest.raises(InputError, match="inside a campaign directory"):
        refuse_nested(campaign / "deep" / "er" / "t.csv", None)
    refuse_nested(campaign / "replays" / "run-0000001", "campaign replay")  # its default
    with pytest.raises(InputError):
        refuse_nested(campaign / "elsewhere", "campaign replay")
    loop = tmp_path / "L"
    loop.mkdir()
    (loop / "loop.json").write_text("{}")  # a loop by its state file alone
    with pytest.raises(InputError, match="inside a loop directory"):
        refuse_nested(loop / "drivers", "analyze")
    with writing_inside(loop):
        refuse_nested(loop / "drivers", "analyze")  # the loop's own stage
        with pytest.raises(InputError, match="inside a campaign directory"):
            refuse_nested(campaign / "x", "maneuver")
    link = tmp_path / "link"
    link.symlink_to(campaign)
    with pytest.raises(InputError, match=str(campaign)):
        refuse_nested(link / "histories", "maneuver")  # links resolved


def test_an_output_is_not_its_own_input(tmp_path):
    table = tmp_path / "t6.csv"
    table.write_text("x")
    with pytest.raises(InputError, match="own input"):
        check_out_dir(tmp_path, "analyze", inputs={"PATH": table})
    (tmp_path / "d").mkdir()  # an empty directory: a campaign directory to be, say
    with pytest.raises(InputError, match="is this command's own input"):
        check_out_dir(tmp_path / "d", "analyze", inputs={"PATH": tmp_path / "d"})
    check_out_dir(tmp_path / "d", "analyze", inputs={"--table": "table6", "--vehicle": None})


def test_one_lock_per_real_path(tmp_path):
    target = tmp_path / "real"
    target.mkdir()
    link = tmp_path / "link"
    link.symlink_to(target)
    assert lock_file(link) == lock_file(target) == tmp_path / ".real.rcsim-lock"
    probe = (
        "from rcsim.analysis.engine.output import OutputLocked, output_lock\n"
        "try:\n"
        f"    with output_lock({str(link)!r}, 'other'):\n"
        "        print('GOT IT')\n"
        "except OutputLocked as exc:\n"
        "    print('REFUSED', exc)\n"
    )
    with output_lock(target, "campaign run"):
        held = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True)
    assert held.stdout.startswith("REFUSED"), held.stdout + held.stderr
    assert f"pid {os.getpid()}, rcsim campaign run" in held.stdout


def test_a_claim_holds_the_lock_from_the_check_to_the_end_of_the_scope(tmp_path):
    out = tmp_path / "m"
    probe = (
        "from rcsim.analysis.engine.output import OutputLocked, output_lock\n"
        "try:\n"
        f"    with output_lock({str(out)!r}, 'other'):\n"
        "        print('GOT IT')\n"
        "except OutputLocked as exc:\n"
        "    print('REFUSED', exc)\n"
    )
    with claim_scope() as scope:
        scope.command = "maneuver"
        check_out_dir(out, "maneuver")  # the check before the work takes the lock ...
        held = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True)
        assert held.stdout.startswith("REFUSED"), held.stdout + held.stderr
        _write(out)  # ... and the write at the end re-enters it
        assert lock_file(out).exists()
    assert not lock_file(out).exists()  # released with the scope
    check_out_dir(tmp_path / "n", "maneuver")  # outside a scope a check locks nothing
    assert not lock_file(tmp_path / "n").exists()


def test_a_failed_claim_leaves_no_parent_directory(tmp_path):
    with pytest.raises(RuntimeError), claim_scope():
        check_out_dir(tmp_path / "a" / "b" / "out", "maneuver")
        assert (tmp_path / "a" / "b").is_dir()  # made for the lock file
        raise RuntimeError("the command failed")
    assert list(tmp_path.iterdir()) == []


def test_lookup_refine_is_refused_before_any_flight_while_another_writes(
    tmp_path, capsys, monkeypatch
):
    # Issue 31: `lookup refine` took no lock; a second writer searched to the end.
    import rcsim.analysis.apps.refinement.outputs as outputs
    from rcsim.analysis.apps.cli import main

    out = tmp_path / "R.csv"
    holder = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "import sys, time\n"
            "from rcsim.analysis.engine.output import output_lock\n"
            f"with output_lock({str(out)!r}, 'lookup refine'):\n"
            "    print('READY', flush=True)\n"
            "    sys.stdin.read()\n",
        ],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert holder.stdout.readline().strip() == "READY"

        def must_not_fly(*args, **kwargs):
            raise AssertionError("flew before taking the lock")

        monkeypatch.setattr(outputs, "run_refinement", must_not_fly)
        argv = ["lookup", "refine", "--table", "table6", "--cases", "3", "--out", str(out)]
        assert main([*argv, "--runs", "4", "--search-runs", "4"]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "being written" in err and f"pid {holder.pid}" in err
    finally:
        holder.communicate("", timeout=60)
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_a_dead_writers_staging_folder_is_removed_by_the_next_writer(tmp_path):
    """``kill -9`` of ``maneuver --overwrite`` left ``.M.tmp-<hex>`` beside the output, full of
    its half-written files, and no later run removed it (issue 38, section 4).  The next writer
    of the output, holding its lock (so the folder's writer is dead), removes it; nothing else
    of that look: another output's, a name that only begins the same, a link, a file."""
    from rcsim.analysis.engine.output import remove_stale_staging

    out = tmp_path / "M"
    _write(out, "maneuver")
    dead = tmp_path / ".M.tmp-0123abcd"
    (dead / "plots").mkdir(parents=True)
    (dead / "history.parquet").write_text("PAR1 half")
    keep = tmp_path / "keep"
    keep.mkdir()
    (keep / "mine.txt").write_text("mine")
    others = {
        ".N.tmp-0123abcd": "dir",  # another output's: its own writer's business
        ".M.tmp-0123abcd.x": "dir",  # not the staging pattern
        ".M.tmp-89abcdef": "link",  # a link to the user's folder: never followed, never removed
        ".M.tmp-fedcba98": "file",
    }
    for name, kind in others.items():
        if kind == "dir":
            (tmp_path / name).mkdir()
        elif kind == "link":
            (tmp_path / name).symlink_to(keep)
        else:
            (tmp_path / name).write_text("x")
    assert remove_stale_staging(out) == []  # without the output's lock: no proof it is dead
    assert dead.exists()
    _write(out, "maneuver", overwrite=True)
    assert not dead.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["M", "keep", *others])
    assert (keep / "mine.txt").read_text() == "mine"
