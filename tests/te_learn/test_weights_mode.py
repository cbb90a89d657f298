"""The weight file honours the umask like every other output (finding A8, session 20 tester A).

Before: ``weights.safetensors`` was created 0600 by safetensors while ``model.json`` and all
other outputs came out ``0666 & ~umask`` (0644 at umask 022): a model directory copied to a
share or handed to the CNC's service user could not be loaded by it.
"""

from __future__ import annotations

import os
import stat

import pytest

from drivelash.te.runtime.persist import save_model


@pytest.mark.parametrize("mask", [0o022, 0o077])
def test_weight_file_mode_is_that_of_model_json(small_trained, tmp_path, mask):
    old = os.umask(mask)
    try:
        d = save_model(small_trained, tmp_path / "m")
    finally:
        os.umask(old)
    modes = {p.name: stat.S_IMODE(p.stat().st_mode) for p in d.iterdir()}
    assert modes["weights.safetensors"] == 0o666 & ~mask, oct(modes["weights.safetensors"])
    assert modes["model.json"] == modes["weights.safetensors"]  # umask 077: both 0600 (control)
