"""The real-data rule (issue 13 item 6): a missing ``../shared/data`` fails under CI=true and
skips locally with a visible reason; the real files are found when present."""

from __future__ import annotations

import pytest

from realdata import SHARED_DATA, shared_data


@pytest.mark.parametrize("value", ["true", "TRUE", "1", "yes"])
def test_missing_real_data_fails_under_ci(monkeypatch, value):
    monkeypatch.setenv("CI", value)
    with pytest.raises(pytest.fail.Exception, match=r"CI=true: \.\./shared/data/emps/NOPE\.mat"):
        shared_data("emps", "NOPE.mat")


@pytest.mark.parametrize("value", [None, "", "false", "0"])
def test_missing_real_data_skips_locally_with_the_path(monkeypatch, value):
    if value is None:
        monkeypatch.delenv("CI", raising=False)
    else:
        monkeypatch.setenv("CI", value)
    with pytest.raises(pytest.skip.Exception, match=r"not available locally: .*/kuka-kr300/NOPE"):
        shared_data("kuka-kr300", "NOPE")


def test_present_real_data_is_returned(monkeypatch):
    """Negative control of the two above: an existing path passes through, CI or not."""
    monkeypatch.setenv("CI", "true")
    if not SHARED_DATA.is_dir():
        pytest.skip(f"../shared/data absent ({SHARED_DATA}); the CI run fails in the real-data tests")
    assert shared_data() == SHARED_DATA
