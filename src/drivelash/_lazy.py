"""PEP 562 lazy public names of a package (``import drivelash`` stays fast)."""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Any


def lazy_names(
    package: str, names: dict[str, str], namespace: dict[str, Any]
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """``__getattr__`` and ``__dir__`` for ``package``: each name in ``names`` (→ defining
    module) is imported on first use and cached in ``namespace`` (the package's globals);
    ``dir(package)`` lists the package's ``__all__`` (``names`` when it has none)."""

    def __getattr__(name: str) -> Any:
        mod = names.get(name)
        if mod is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(mod), name)
        namespace[name] = value
        return value

    def __dir__() -> list[str]:
        # the curated namespace (python-control style): ``__all__``, not the module's internals
        # (``TYPE_CHECKING``, the lazy table, imported helpers)
        return sorted(namespace.get("__all__", names))

    return __getattr__, __dir__


def lazy_ufuncs(
    module: str, kernels: dict[str, tuple[Any, int]], namespace: dict[str, Any]
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """``__getattr__`` and ``__dir__`` for a module whose NumPy ufuncs wrap scalar ``@njit`` kernels.

    Each name in ``kernels`` (→ ``(kernel, number of float64 arguments)``) becomes
    ``numba.vectorize(["float64(float64, …)"], cache=True)(kernel.py_func)`` on first use and
    is cached in ``namespace``. Built at import instead, the eager signatures compiled — or
    loaded from numba's cache — every ufunc in every process that imported the module, used or
    not: ≈ 1.2 s of each CLI start with a warm cache (session 26).
    """

    def __getattr__(name: str) -> Any:
        spec = kernels.get(name)
        if spec is None:
            raise AttributeError(f"module {module!r} has no attribute {name!r}")
        from numba import vectorize

        kernel, n_args = spec
        ufunc = vectorize([f"float64({', '.join(['float64'] * n_args)})"], cache=True)(kernel.py_func)
        ufunc.__doc__ = kernel.__doc__
        namespace[name] = ufunc
        return ufunc

    def __dir__() -> list[str]:
        return sorted(set(namespace) | set(kernels))

    return __getattr__, __dir__
