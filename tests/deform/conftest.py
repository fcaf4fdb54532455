"""Fixtures the editor's test files share."""

import pytest


@pytest.fixture(scope="module")
def blob_rig(blob):
    """The session's bumpy blob bound to a 300-vertex cage."""
    from hybridedit import build_rig

    return build_rig(blob, cage_size=300)
