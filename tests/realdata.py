"""Real data under ``../shared/data``: one rule for every test that reads it (issue 13 item 6).

Imported as ``from realdata import shared_data``: ``from conftest import`` is ambiguous once a
sub-folder has its own ``conftest.py``.
"""

from __future__ import annotations

import pytest

SHARED_DATA = __import__("pathlib").Path(__file__).resolve().parents[1].parent / "shared" / "data"


def in_ci() -> bool:
    """True when the environment says CI (``CI=true``, ``1`` or ``yes``, as CI services set it)."""
    import os

    return os.environ.get("CI", "").strip().lower() in {"true", "1", "yes"}


def shared_data(*parts: str):
    """Path of a real-data file or folder under ``../shared/data`` (e.g. ``"emps", "DATA_EMPS.mat"``).

    When it is missing the calling test **fails** under ``CI=true`` (CI must run the real-data
    checks) and **skips** otherwise, with the path in the reason (shown by ``-ra``).
    """
    p = SHARED_DATA.joinpath(*parts)
    if not p.exists():
        what = "/".join(("../shared/data", *parts))
        if in_ci():
            pytest.fail(f"real data missing under CI=true: {what} ({p} does not exist)", pytrace=False)
        pytest.skip(f"real data not available locally: {what} ({p} does not exist)")
    return p
