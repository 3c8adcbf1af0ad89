"""Controllers by name (rcsim.lookup.registry): the one list, and bad input named in library
terms."""

from __future__ import annotations

import pytest

from rcsim.lookup.pattern_recognition import LookupController
from rcsim.lookup.phase_plane import PhasePlaneController
from rcsim.lookup.registry import CONTROLLERS, make_controller
from rcsim.models.errors import InputError
from rcsim.spacecraft.vehicle import Vehicle

#: The paper's vehicle (paper.toml).
PAPER = Vehicle.load()


def test_every_listed_controller_builds(paper):
    built = {name: make_controller(name, paper) for name in CONTROLLERS}
    assert isinstance(built["phase-plane"], PhasePlaneController)
    assert isinstance(built["lookup"], LookupController)
    assert set(built) == {"phase-plane", "lookup"}


def test_unknown_controller_lists_the_names():
    with pytest.raises(InputError, match="'bang-bang'; choose one of phase-plane, lookup"):
        make_controller("bang-bang", PAPER)


def test_table_for_phase_plane_is_refused_without_naming_cli_flags(paper):
    with pytest.raises(InputError) as err:
        make_controller("phase-plane", paper, table="x.csv")
    message = str(err.value)
    assert message == "table is only for the lookup controller, not 'phase-plane' (got 'x.csv')"
    assert err.value.parameter == "table"
    assert "--" not in message  # the library names its parameters, the CLI translates


def test_missing_table_names_the_path(tmp_path):
    missing = tmp_path / "missing_table.csv"
    with pytest.raises(InputError) as err:
        make_controller("lookup", PAPER, table=missing)
    assert str(missing) in str(err.value) and "not found" in str(err.value)
    assert "--" not in str(err.value)
