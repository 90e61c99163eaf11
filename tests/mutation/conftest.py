"""Import faultlab.mutation before the test modules import libcst: it silences libcst 1.0's upstream
DeprecationWarning (mypy_extensions.TypedDict) for the whole session."""

import faultlab.mutation  # noqa: F401

from tests.mutation.usercode import user_package  # noqa: E402,F401  (fixture)
