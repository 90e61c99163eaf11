"""Variant names resolved to the fault each runs (faultlab.runner.variants)."""

import subprocess
import sys

import pytest

from faultlab.errors import FaultError
from faultlab.faults import get_fault
from faultlab.runner.variants import resolve_variant
from faultlab.vocabulary import BASELINE, REPLICA


def test_unmodified_variants_run_no_fault_and_fault_names_the_registered_fault():
    assert resolve_variant(BASELINE) is None and resolve_variant(REPLICA) is None
    assert resolve_variant("motion_sign_error") is get_fault("motion_sign_error")
    f = get_fault("missing_angle_wrap")
    assert resolve_variant(f) is f


def test_unknown_names_are_a_fault_error():
    with pytest.raises(FaultError, match="unknown fault 'motion_sign_eror'"):
        resolve_variant("motion_sign_eror")


def test_resolving_a_fault_does_not_load_the_mutation_package():
    code = ("import sys; from faultlab.runner.variants import resolve_variant; "
            "resolve_variant('motion_sign_error'); print('faultlab.mutation' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
