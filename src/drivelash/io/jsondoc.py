"""Versioned JSON documents of the toolkit (campaign manifests, model metadata), read safely.

:func:`read_document` reads a JSON file and validates it against a pydantic model; every
problem is one :class:`~drivelash.errors.DataError` line naming the file and the key
(``runs[3].load``), never a traceback. :func:`inside` resolves a file name stored in a
document strictly inside its directory (no absolute paths, no ``..``, no symlink out).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, TypeVar

from pydantic import BaseModel, ConfigDict, ValidationError

from drivelash.errors import DataError

__all__ = ["Document", "format_loc", "inside", "read_document", "read_raw_document", "validate_document"]

M = TypeVar("M", bound=BaseModel)

#: Largest document read [bytes]: metadata, never bulk data (a guard against a huge file).
MAX_DOCUMENT_BYTES = 64 * 2**20


class Document(BaseModel):
    """Base of a JSON document: unknown keys are errors, values frozen."""

    model_config = ConfigDict(extra="forbid", frozen=True)


def format_loc(loc: tuple[Any, ...]) -> str:
    """``('runs', 3, 'load')`` → ``runs[3].load``."""
    out = ""
    for p in loc:
        if isinstance(p, int):
            out += f"[{p}]"
        else:
            out += ("." if out else "") + str(p)
    return out or "(document)"


def _message(err: dict[str, Any]) -> str:
    kind = err.get("type", "")
    if kind in ("extra_forbidden", "unexpected_keyword_argument"):
        return "unknown key"
    if kind in ("missing", "missing_keyword_argument"):
        return "missing"
    msg = str(err.get("msg", "invalid value")).replace("\n", " ")
    for prefix in ("Value error, ", "Assertion failed, "):
        if msg.startswith(prefix):
            msg = msg[len(prefix) :]
    got = err.get("input")
    if kind not in ("value_error", "assertion_error") and not isinstance(got, dict | list):
        text = repr(got)
        msg = f"{msg} (got {text[:60]}{'…' if len(text) > 60 else ''})"
    return msg


def validate_document(data: Any, model: type[M], path: str | Path) -> M:
    """Validate parsed JSON ``data`` against ``model``; one-line :class:`DataError` naming file and key."""
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        errors = exc.errors()
        # an unknown key first (a misspelt key also shows up as the missing one)
        errors.sort(key=lambda e: e.get("type") not in ("extra_forbidden", "unexpected_keyword_argument"))
        e = errors[0]
        raise DataError(
            f"key '{format_loc(tuple(e.get('loc', ())))}': {_message(e)}", path=str(path)
        ) from None
    except (TypeError, ValueError, RecursionError) as exc:  # a dataclass check outside pydantic's wrapping
        raise DataError(f"invalid document ({type(exc).__name__}: {exc})", path=str(path)) from None


def _no_constants(name: str) -> float:
    raise ValueError(f"non-standard JSON constant {name}")


def read_document(path: str | Path, model: type[M]) -> M:
    """Read the JSON file ``path`` and validate it against ``model``.

    Strict JSON: ``NaN``/``Infinity`` are refused, as are files over
    :data:`MAX_DOCUMENT_BYTES`.

    Raises
    ------
    DataError
        Missing, unreadable, too large, not JSON, or not matching the schema —
        one line naming the file and the key.
    """
    p = Path(path)
    try:
        size = p.stat().st_size
    except FileNotFoundError:
        raise DataError("missing", path=str(p)) from None
    except OSError as exc:
        raise DataError(f"cannot read ({exc.strerror or exc})", path=str(p)) from None
    if not p.is_file():
        raise DataError("not a regular file", path=str(p))
    if size > MAX_DOCUMENT_BYTES:
        raise DataError(f"{size} bytes: too large for a metadata document", path=str(p))
    try:
        text = p.read_text(encoding="utf-8")
        data = json.loads(text, parse_constant=_no_constants)
    except UnicodeDecodeError:
        raise DataError("not a UTF-8 text file", path=str(p)) from None
    except json.JSONDecodeError as exc:
        raise DataError(f"malformed JSON ({exc.msg}, line {exc.lineno})", path=str(p)) from None
    except (ValueError, RecursionError) as exc:
        raise DataError(f"malformed JSON ({exc})", path=str(p)) from None
    except OSError as exc:
        raise DataError(f"cannot read ({exc.strerror or exc})", path=str(p)) from None
    if not isinstance(data, dict):
        raise DataError(f"must be a JSON object, got a {type(data).__name__}", path=str(p))
    return validate_document(data, model, p)


class _Any(Document):
    model_config = ConfigDict(extra="allow", frozen=True)


def read_raw_document(path: str | Path) -> dict[str, Any]:
    """The JSON object in ``path`` (strict JSON, size-limited), not yet validated.

    Used to read ``format`` and ``version`` before choosing the schema.
    """
    return read_document(path, _Any).model_dump()


def inside(directory: str | Path, name: str, *, document: str | Path, key: str) -> Path:
    """``directory / name``, refused unless it stays inside ``directory``.

    ``name`` must be relative, without ``..`` components, and must not leave the
    directory through a symbolic link.

    Parameters
    ----------
    directory : path
        The directory the document describes.
    name : str
        The stored file name.
    document, key : path, str
        Named in the error message.
    """
    d = Path(directory)
    if not isinstance(name, str) or not name or "\x00" in name:
        raise DataError(f"key '{key}': not a file name", path=str(document))
    rel = Path(name)
    if rel.is_absolute() or any(part == ".." for part in rel.parts) or name.startswith("~"):
        raise DataError(f"key '{key}': file {name!r} is outside the directory", path=str(document))
    full = d / rel
    try:
        real = full.resolve()
        base = d.resolve()
    except (OSError, RuntimeError):
        raise DataError(f"key '{key}': cannot resolve {name!r}", path=str(document)) from None
    if real != base and base not in real.parents:
        raise DataError(f"key '{key}': file {name!r} leads outside the directory", path=str(document))
    return full
