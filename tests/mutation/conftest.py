"""Import faultlab.mutation before the test modules import libcst: it silences libcst 1.0's upstream
DeprecationWarning (mypy_extensions.TypedDict) for the whole session."""

import faultlab.mutation  # noqa: F401
