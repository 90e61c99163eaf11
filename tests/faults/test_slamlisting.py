"""The listing of the built-in SLAMs (faultlab.faults.slamlisting)."""

import dataclasses

from faultlab.faults import builtin_faults, list_slams
from faultlab.slam.registry import BUILTIN_SLAMS


def test_each_slam_is_listed_with_its_units_and_the_builtin_faults_replacing_one_of_them():
    listing = list_slams()
    faults = list(builtin_faults().values())
    assert [s.name for s in listing.slams] == list(BUILTIN_SLAMS)
    assert listing.n_builtin_faults == len(faults)
    for s in listing.slams:
        kind = BUILTIN_SLAMS[s.name]
        units = {f.name for f in dataclasses.fields(kind.steps)} if kind.steps is not None else set()
        assert s.n_units == len(units)
        assert s.n_faults == sum(f.step in units for f in faults)  # a fault applies iff its unit exists
        assert s.available == kind.available


def test_the_table_has_one_row_per_slam_and_says_how_to_select_one():
    text = list_slams().format()
    rows = text.splitlines()[1:1 + len(BUILTIN_SLAMS)]
    assert [r.split()[0] for r in rows] == list(BUILTIN_SLAMS)
    assert text.endswith('select one in an experiment file with [slam] name = "NAME"')
