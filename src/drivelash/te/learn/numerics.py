"""One floating-point code path for training the TE network on every x86-64 CPU.

PyTorch picks its CPU kernels by the instruction set it finds: ATen's vectorised
operators (``AVX512`` or ``AVX2``) and MKL's GEMM branch. Their summation orders differ,
and the network's training is chaotic in the last bit: on the seed-0 campaign the same
``drivelash te fit`` gave a +x training MAE of 0.0497 µm on a CPU with AVX-512 and
0.0546 µm with the AVX2 branch forced on that same CPU (Hyperband chose another learning
rate: 0.0121 against 0.0064), so the README's figures held only on the CPU type they were
measured on (docs/assumptions.md, "Transmission-error learning", stage 1).

:func:`pin_training_numerics` selects the AVX2 branch of both before the first torch
operation of the process — ``ATEN_CPU_CAPABILITY=avx2`` and ``MKL_CBWR=AVX2`` (oneMKL's
conditional numerical reproducibility: the same results on every Intel CPU with AVX2) —
unless the user has set either variable. Worker processes inherit the environment.
Whatever is in force is recorded in the model (``info["numerics"]``), so a figure can be
traced to the code path that produced it. oneMKL does not promise the AVX2 branch's
results on non-Intel CPUs; that limit is stated, not hidden.
"""

from __future__ import annotations

import os
import sys
import warnings
from typing import Any

__all__ = ["PINNED_NUMERICS", "pin_training_numerics"]

#: The environment that fixes torch's CPU code path for training (set unless the user set it).
PINNED_NUMERICS: dict[str, str] = {"ATEN_CPU_CAPABILITY": "avx2", "MKL_CBWR": "AVX2"}


def pin_training_numerics() -> dict[str, Any]:
    """Fix torch's CPU code path (ATen AVX2 kernels, oneMKL CNR branch AVX2) for training.

    Call before the first torch operation of the process (torch may already be imported:
    both libraries read the variables on first use). A variable the user has set is left
    as it is. If torch has already chosen another ATen code path, a ``UserWarning`` says
    so (the fit is then reproducible on this CPU type only).

    Returns
    -------
    dict
        ``{"ATEN_CPU_CAPABILITY": …, "MKL_CBWR": …, "aten_in_use": …, "pinned": bool}`` —
        the variables in force, the ATen code path torch reports, and whether both are
        the pinned ones.
    """
    for key, value in PINNED_NUMERICS.items():
        os.environ.setdefault(key, value)
    import torch

    in_use = str(torch.backends.cpu.get_cpu_capability())
    asked = os.environ["ATEN_CPU_CAPABILITY"]
    pinned = (
        asked.lower() == PINNED_NUMERICS["ATEN_CPU_CAPABILITY"]
        and in_use.lower() == asked.lower()
        and os.environ["MKL_CBWR"].upper().split(",")[0] == PINNED_NUMERICS["MKL_CBWR"]
    )
    if in_use.lower() != asked.lower() and not getattr(pin_training_numerics, "_warned", False):
        pin_training_numerics._warned = True  # type: ignore[attr-defined]
        warnings.warn(
            f"torch runs its {in_use} kernels in this process, not the {asked} asked for (set"
            " after the first torch operation, or not supported by this CPU): the fitted TE network"
            " may differ from other machines'; set ATEN_CPU_CAPABILITY=avx2 and MKL_CBWR=AVX2 before"
            " the first torch operation",
            UserWarning,
            stacklevel=2,
        )
    return {
        "ATEN_CPU_CAPABILITY": asked,
        "MKL_CBWR": os.environ["MKL_CBWR"],
        "aten_in_use": in_use,
        "pinned": bool(pinned),
        "torch": str(torch.__version__),
        "platform": sys.platform,
    }
