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
