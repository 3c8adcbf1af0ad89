"""Unknown keys in TOML inputs (:class:`rcsim.models.toml_reader.Reader`, issue 18 review: a
misspelt top-level table was refused without saying what the file takes).

Oracle: the reader's contract -- the keys a table takes are the ones the reading code asked
for; the closest one (difflib's ratio >= 0.6) is suggested; a manifest's records (checksums,
keys marked unlisted) are accepted but never offered.
"""

from __future__ import annotations

import pytest

from rcsim.models.errors import InputError
from rcsim.models.toml_reader import Reader


def test_unknown_key_names_the_closest_and_every_key_taken():
    r = Reader({"mass": {}, "propelant": {}}, "", "v.toml")
    r.table_("mass")
    r.table_("propellant")
    r.raw("jet")
    with pytest.raises(InputError) as err:
        r.done()
    assert str(err.value) == (
        "v.toml: unknown key 'propelant'; did you mean 'propellant'? "
        "(the top level takes mass, propellant, jet)"
    )


def test_records_are_accepted_but_not_offered():
    r = Reader({"name": "lookup", "tabel": "t.csv"}, "controller", "s.toml")
    r.choice("name", None, ("lookup",))
    r.has("table_sha256")
    r.unlisted.add("jets_off")
    r.has("jets_off")
    r.takes("table")
    with pytest.raises(InputError) as err:
        r.done()
    message = str(err.value)
    assert "did you mean 'controller.table'?" in message
    assert message.endswith("([controller] takes name, table)")


def test_a_note_names_the_block():
    r = Reader({"direction": [0, 0, 0]}, "jet[9]", "v.toml", note=" (fwd_yaw_plus)")
    assert str(r.error("direction", "must be a non-zero vector", [0, 0, 0])) == (
        "v.toml: jet[9].direction (fwd_yaw_plus): must be a non-zero vector (got [0, 0, 0])"
    )
