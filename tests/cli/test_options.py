import argparse

import pytest

from faultlab.cli.options import add_execution_options, positive_int


def test_positive_int():
    assert positive_int("3") == 3
    for bad in ("0", "-1", "x", "1.5"):
        with pytest.raises(argparse.ArgumentTypeError, match="positive integer"):
            positive_int(bad)


def test_execution_options_defaults_and_choices():
    p = argparse.ArgumentParser()
    add_execution_options(p)
    args = p.parse_args([])
    assert (args.backend, args.force_new, args.no_progress) == ("loky", False, False)
    with pytest.raises(SystemExit):
        p.parse_args(["--backend", "spark"])
