"""Output paths a user can get wrong in ways the corpus's data cannot express (symbolic links).

Issue 17: ``--out`` through a symbolic link to nothing failed after the work with
"lnk: File exists", naming neither the flag nor the cause.
"""

from rcsim.analysis.apps.cli import main


def test_out_through_a_dangling_link_is_refused_first(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "lnk").symlink_to(tmp_path / "nowhere")
    rc = main(["maneuver", "--attitude-deg", "0", "0", "5", "--out", "lnk"])
    err = capsys.readouterr().err
    assert rc == 2
    assert err.count("\n") == 1 and err.startswith("rcsim: error: --out ")
    assert "symbolic link" in err and "nowhere" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["lnk"]  # nothing written, link kept
    assert (tmp_path / "lnk").is_symlink()
