"""Outputs of a command: validated before any work, staged, and put in place together.

Every command that writes files does it through :class:`Outputs`::

    with Outputs("estimate", inputs=[trace_path, config_path], force=force) as out:
        j = out.file(json_out, option="--json", kinds=JSON_EXTENSIONS)   # None stays None
        p = out.file(plot, option="--plot", kinds=PLOT_EXTENSIONS)
        d = out.directory(model_dir, option="-o")                       # written as a whole
        ...                                                              # the work
        write_json(out.staging(j), summary)                              # temp name next to j
        save_figure(fig, out.staging(p))                                 # drivelash.report
    # a clean exit renames every staged output into place, together, under a lock;
    # an exception (or SIGTERM, see drivelash.cli) removes the staged files and leaves
    # every target as it was.

What a user can rely on (each point is tested in ``tests/io/test_outputs.py``):

- **Validation before any work**: the parent directory exists, is a directory and is
  writable; a file output is not an existing directory (nor a device or FIFO); its
  extension is one the output kind accepts; it is not an input of the command (same
  resolved path or the same file through a hard link), not inside an input directory
  (a model or campaign), and not the path of another output of the same command.
  Each problem is one line: ``--json run.parquet: is an input of this command; choose
  another path``.
- **Symbolic links are written through**: an output path that is a link (or a chain of
  links) to an existing file or directory names that target: it is checked (ownership,
  inputs, a writable directory) and replaced atomically in its own directory, and the link
  stays as it is (:func:`through_link`; library writes too). A dangling link is refused in
  one line (it may point into an unmounted share); ``--force`` replaces the link itself.
- **Never lose a user's file**: an existing file or directory at an output path is
  replaced only if it is recognisably a drivelash output (:func:`is_own_output`) or
  with ``force=True`` (``--force``); the check is repeated under the lock at commit.
- **Atomic as a set**: files are written under hidden temporary names next to their
  targets (``.NAME.drivelash-PID-RAND.part``), directories as a hidden sibling
  directory; the final renames run under an exclusive :func:`fcntl.flock` on each
  target's parent directory (taken in sorted order, no lock files) with SIGTERM/SIGINT
  blocked, so two concurrent runs never leave a mixed set. A directory is swapped in
  with ``renameat2(RENAME_EXCHANGE)`` where the kernel offers it (else two renames;
  the old copy is removed last). A rename that fails half-way through the set (an
  immutable target) puts the outputs already renamed back, from hidden ``….old`` hard
  links of the previous files. A killed process (SIGKILL) can leave only hidden
  ``….part`` names, which no reader accepts as a recording; they are swept by the next
  commit to the same target once their process is gone.
- **A failed write is one line**: an ``OSError`` while an output is written (a full disk,
  a quota, a read-only device; :meth:`Outputs.write_error`) leaves the targets as they
  were and is reported as ``--json out.json: cannot write it: No space left on device; the
  existing files were left as they were``, exit code 2, not a traceback.

Signatures (how a drivelash output is recognised) are listed in
``docs/assumptions.md`` ("Outputs and bad input").
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import errno
import fcntl
import json
import math
import os
import re
import shutil
import signal
import struct
import tempfile
import threading
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from drivelash import __version__
from drivelash.errors import OutputError

__all__ = [
    "DIRECTORY_MARKER",
    "GENERATOR",
    "HTML_EXTENSIONS",
    "JSON_EXTENSIONS",
    "PLOT_EXTENSIONS",
    "TEXT_EXTENSIONS",
    "TOML_EXTENSIONS",
    "TRACE_EXTENSIONS",
    "Outputs",
    "atomic_write",
    "write_target",
    "dumps_json",
    "final_suffix",
    "is_own_output",
    "is_staging_path",
    "output_command",
    "forget_written",
    "note_written",
    "written_outputs",
    "signature",
    "through_link",
    "jsonable",
    "write_json",
]

#: The signature our outputs carry (JSON ``generator`` key, image metadata, HTML meta tag).
GENERATOR = f"drivelash {__version__}"

#: Plot formats: what matplotlib writes *and* where we can stamp our signature.
PLOT_EXTENSIONS: tuple[str, ...] = (".png", ".pdf", ".svg")
#: HTML reports.
HTML_EXTENSIONS: tuple[str, ...] = (".html",)
#: JSON documents (written with :func:`write_json`).
JSON_EXTENSIONS: tuple[str, ...] = (".json",)
#: TOML fragments (first line ``# drivelash …``).
TOML_EXTENSIONS: tuple[str, ...] = (".toml",)
#: Plain text tables (first line ``# drivelash …`` or ``<!-- drivelash … -->``).
TEXT_EXTENSIONS: tuple[str, ...] = (".csv", ".txt", ".md")
#: Recordings we write (:func:`drivelash.io.formats.write_trace`; ``.txt`` is read as CSV but
#: never written as a recording).
TRACE_EXTENSIONS: tuple[str, ...] = (".parquet", ".pq", ".csv", ".h5", ".hdf5", ".hdf", ".mat")

#: Marker file written into every output directory (JSON, with the generator key).
DIRECTORY_MARKER = ".drivelash-output"

_STAGE_RE = re.compile(
    r"^\.(?P<name>.+)\.drivelash-(?P<pid>\d+)-(?P<rand>[A-Za-z0-9_]+)\.(?P<kind>part|old)$"
)
_HEAD = 8192

#: Bytes a temporary name ``.NAME.drivelash-PID-RAND.part`` adds to NAME: the dots, the
#: ``drivelash-`` tag, a PID of up to 7 digits (Linux ``pid_max`` ≤ 4 194 304), the 8 random
#: characters of :mod:`tempfile` and ``.part``; an output name longer than the file system's
#: limit less this is refused before any work (its temporary name could not be created).
STAGE_NAME_OVERHEAD = 33

#: ``errno`` values that mean "the output cannot be written" whatever file they name:
#: a full disk, a full quota, a file above the file-size limit, a read-only or failing device.
WRITE_ERRNOS: frozenset[int] = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EROFS, errno.EIO})

#: Staging path → command of the :class:`Outputs` that made it (read by :func:`signature`).
_STAGED_BY: dict[str, str] = {}

#: Outputs put in place by :meth:`Outputs.commit` (or noted by :func:`note_written`) in this
#: process since :func:`forget_written`: key → how the user sees it (the CLI's line after
#: Ctrl-C or SIGTERM says which were written).
_WRITTEN: dict[str, str] = {}

#: Formats whose signature records the command that wrote the file (:func:`signature`);
#: a file of these kinds that carries only ``drivelash <version>`` was written before the
#: command was recorded (or by a library call), so a command replaces it only with ``--force``.
_RECORDS_COMMAND: tuple[str, ...] = (".json", ".html", ".htm", ".png", ".pdf", ".svg")
#: Recordings (and CSV text tables): the command is in the metadata's ``generator`` when the
#: file was written by a command since it was recorded; an older one still counts as ours.
_RECORDING_KINDS: tuple[str, ...] = (".parquet", ".pq", ".csv", ".h5", ".hdf5", ".hdf", ".mat")


# =========================================================================== written
def written_outputs() -> list[str]:
    """Outputs committed in this process since :func:`forget_written` (as the user named them)."""
    return list(_WRITTEN.values())


def note_written(key: str, shown: str) -> None:
    """Record an output written outside :class:`Outputs` (a store's committed transaction)."""
    _WRITTEN[key] = shown


def forget_written() -> None:
    """Start a new count for :func:`written_outputs` (the CLI calls it when a command starts)."""
    _WRITTEN.clear()


# =========================================================================== signature
def signature(path: str | Path | None = None) -> str:
    """The signature to stamp into the output written at ``path``.

    ``drivelash <version> <command>`` for a staging path of an :class:`Outputs` with a
    command (so a later run knows which command wrote the file), else :data:`GENERATOR`.
    """
    if path is not None:
        cmd = _STAGED_BY.get(os.fspath(path))
        if cmd:
            return f"{GENERATOR} {cmd}"
    return GENERATOR


def _command_in(sig: str) -> str:
    """The command recorded in a signature ``drivelash <version> <command>`` ('' if none)."""
    parts = sig.strip().split(" ", 2)
    return parts[2].strip() if len(parts) == 3 and parts[0] == "drivelash" else ""


# =========================================================================== JSON
def jsonable(obj: Any) -> Any:
    """``obj`` as plain JSON types: numpy scalars/arrays converted, non-finite floats → ``None``.

    Dict keys become strings; tuples and sets become lists; :class:`~pathlib.Path` becomes
    its string; dataclasses their fields. Anything else raises :class:`TypeError`.
    """
    if obj is None or isinstance(obj, bool | str):
        return obj
    if isinstance(obj, int):
        return int(obj)
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, np.generic):
        return jsonable(obj.item())
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, Mapping):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple | set | frozenset):
        return [jsonable(v) for v in obj]
    if isinstance(obj, os.PathLike):
        return os.fspath(obj)
    import dataclasses

    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return jsonable(dataclasses.asdict(obj))
    raise TypeError(f"not JSON-serialisable: {type(obj).__name__}")


def dumps_json(obj: Mapping[str, Any], *, indent: int | None = 2, generator: str = GENERATOR) -> str:
    """Strict JSON text of a mapping with ``"generator": "drivelash <version>"`` first.

    Non-finite floats become ``null`` (JSON has no NaN/Infinity); numpy types are
    converted (:func:`jsonable`). The text ends with a newline.
    """
    if not isinstance(obj, Mapping):
        raise TypeError(f"write_json needs a mapping at the top level, got {type(obj).__name__}")
    doc = {"generator": generator, **{k: v for k, v in jsonable(obj).items() if k != "generator"}}
    return json.dumps(doc, indent=indent, allow_nan=False, ensure_ascii=False) + "\n"


def write_json(path: str | Path, obj: Mapping[str, Any], *, indent: int | None = 2) -> Path:
    """Write ``obj`` as strict JSON (see :func:`dumps_json`); the one JSON writer of the project.

    Parameters
    ----------
    path : str or Path
        A staging path from :meth:`Outputs.staging` (written directly) or any other path
        (written atomically: temporary name, then renamed).
    obj : Mapping
        The document; a ``"generator"`` key is put first.
    indent : int, optional
        Indentation (``None``: one line).
    """
    p = Path(path)
    text = dumps_json(obj, indent=indent, generator=signature(p))
    with write_target(p) as w:
        w.write_text(text, encoding="utf-8")
    return p


# =========================================================================== names
def is_staging_path(path: str | Path) -> bool:
    """Whether ``path`` is a temporary name made by :class:`Outputs` (``.NAME.drivelash-….part``)."""
    m = _STAGE_RE.match(Path(path).name)
    return bool(m and m["kind"] == "part")


def final_name(path: str | Path) -> str:
    """File name the output at ``path`` will have (the target's name for a staging path)."""
    name = Path(path).name
    m = _STAGE_RE.match(name)
    return m["name"] if m else name


def final_suffix(path: str | Path) -> str:
    """Lower-case extension of the output's final name (works on staging paths)."""
    return Path(final_name(path)).suffix.lower()


def _writable_dir(directory: Path) -> bool:
    """Whether files can be created in ``directory`` (access for this user and a write bit)."""
    mode = directory.stat().st_mode
    return os.access(directory, os.W_OK | os.X_OK) and bool(mode & 0o222)


def _name_room(directory: Path, name: str) -> tuple[int, int, int]:
    """``name``'s length [bytes], the longest name that leaves room for the temporary name, and
    the file system's NAME_MAX in ``directory``."""
    name_max = _name_max(directory)
    return len(os.fsencode(name)), name_max - STAGE_NAME_OVERHEAD, name_max


def _name_max(directory: Path) -> int:
    """Longest file name [bytes] the file system of ``directory`` allows (255 if it does not say)."""
    try:
        return int(os.pathconf(directory, "PC_NAME_MAX"))
    except (OSError, ValueError):
        return 255


def through_link(path: Path) -> Path:
    """Where writing ``path`` puts the content: the file a symbolic link at ``path`` points to
    (resolved through every link), else ``path`` itself.

    The one rule of every writer: an output named by a link is written through it, the target
    replaced atomically in the target's own directory, the link left as it is (a ``latest.json``
    link into a run directory stays a link).
    """
    return Path(os.path.realpath(path)) if path.is_symlink() else path


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _new_stage(target: Path, directory: bool) -> Path:
    """Create a hidden temporary file or directory next to ``target``."""
    prefix = f".{target.name}.drivelash-{os.getpid()}-"
    if directory:
        tmp = Path(tempfile.mkdtemp(prefix=prefix, suffix=".part", dir=target.parent))
        os.chmod(tmp, 0o777 & ~_umask())
    else:
        fd, name = tempfile.mkstemp(prefix=prefix, suffix=".part", dir=target.parent)
        os.close(fd)
        tmp = Path(name)
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp creates 0600; give the usual permissions
    return tmp


def _remove(path: Path) -> None:
    with contextlib.suppress(FileNotFoundError):
        if path.is_dir() and not path.is_symlink():
            shutil.rmtree(path, ignore_errors=True)
        else:
            path.unlink()


def _pid_alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _sweep_stale(target: Path) -> None:
    """Remove temporary names of ``target`` left by processes that no longer exist."""
    try:
        names = os.listdir(target.parent)
    except OSError:
        return
    for n in names:
        m = _STAGE_RE.match(n)
        if m and m["name"] == target.name and not _pid_alive(int(m["pid"])):
            _remove(target.parent / n)


# =========================================================================== signatures
def _head(path: Path, n: int = _HEAD) -> bytes:
    with path.open("rb") as fh:
        return fh.read(n)


def _png_signature(path: Path) -> str | None:
    with path.open("rb") as fh:
        if fh.read(8) != b"\x89PNG\r\n\x1a\n":
            return None
        while True:
            hdr = fh.read(8)
            if len(hdr) < 8:
                return None
            n, kind = struct.unpack(">I4s", hdr)
            if kind in (b"IDAT", b"IEND"):
                return None
            if kind == b"tEXt" and n < 65536:
                key, _, value = fh.read(n).partition(b"\x00")
                if key == b"Software" and value.startswith(b"drivelash"):
                    return value.decode("latin-1")
                fh.seek(4, os.SEEK_CUR)
            else:
                fh.seek(n + 4, os.SEEK_CUR)


def _pdf_signature(path: Path) -> str | None:
    size = path.stat().st_size
    with path.open("rb") as fh:
        if fh.read(5) != b"%PDF-":
            return None
        fh.seek(max(0, size - 65536))
        tail = fh.read()
    m = re.search(rb"/Creator \((drivelash[^)\\]*)\)", tail)
    return m[1].decode("latin-1") if m else None


def _first_line(path: Path) -> bytes:
    return _head(path, 512).split(b"\n", 1)[0].strip()


def _com_signed(path: Path) -> bool:
    """A HEIDENHAIN table written by ``te export``: ``[END]`` followed by a ``drivelash`` line."""
    with path.open("rb") as fh:
        fh.seek(0, os.SEEK_END)
        fh.seek(max(0, fh.tell() - 4096))
        tail = fh.read()
    return re.search(rb"\n\[END\]\r?\ndrivelash ", tail) is not None


def _hdf5_meta(path: Path) -> str | None:
    import h5py

    try:
        with h5py.File(path, "r") as f:
            if "drivelash_meta" not in f.attrs:
                return None
            v = f.attrs["drivelash_meta"]
            return v.decode("utf-8", "replace") if isinstance(v, bytes) else str(v)
    except (OSError, ValueError):
        return None


def _mat_meta(path: Path) -> str | None:
    head = _head(path, 128)
    if head.startswith(b"MATLAB 7.3"):
        return _hdf5_meta(path)
    import scipy.io

    try:
        if not any(name == "drivelash_meta" for name, _, _ in scipy.io.whosmat(path)):
            return None
        v = scipy.io.loadmat(path, variable_names=["drivelash_meta"])["drivelash_meta"]
        return "".join(str(x) for x in np.asarray(v).reshape(-1))
    except Exception:  # noqa: BLE001 - any unreadable file is simply "not ours"
        return None


def _parquet_meta(path: Path) -> str | None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    try:
        md = pq.read_schema(path).metadata or {}
    except (pa.ArrowException, OSError, ValueError):
        return None
    v = md.get(b"drivelash.meta")
    return None if v is None else v.decode("utf-8", "replace")


def _recording_command(meta_text: str | None) -> str | None:
    """Command recorded in a recording's metadata (``generator``); '' if it records none."""
    if meta_text is None:
        return None
    try:
        doc = json.loads(meta_text)
    except ValueError:
        return ""
    gen = doc.get("generator") if isinstance(doc, dict) else None
    return _command_in(gen) if isinstance(gen, str) else ""


def is_own_output(path: str | Path) -> bool:
    """Whether the existing file or directory at ``path`` is recognisably a drivelash output.

    Rules (by the extension of ``path``; see ``docs/assumptions.md``):

    - directory: contains the marker file :data:`DIRECTORY_MARKER`, or is empty;
    - ``.json``: the document starts with ``{"generator": "drivelash …"``;
    - ``.html``: ``<meta name="generator" content="drivelash…">`` in its head;
    - ``.png``: a ``tEXt`` chunk ``Software`` starting with ``drivelash`` (before the image data);
      ``.pdf``: ``/Creator (drivelash…)``; ``.svg``: ``<dc:title>drivelash…`` in its metadata;
    - ``.parquet``/``.pq``: schema metadata key ``drivelash.meta``;
    - ``.csv``/``.txt``/``.toml``: first line starts with ``# drivelash``; ``.md``: first line
      ``<!-- drivelash``;
    - ``.h5``/``.hdf5``/``.hdf``, MAT v7.3: root attribute ``drivelash_meta``; MAT v5: a
      variable ``drivelash_meta``;
    - CNC tables (``te export``): ``.ini`` (SINUMERIK init program) first line, or the line
      after the program header ``%_N_…``, starts with ``; drivelash``; ``.com`` (HEIDENHAIN
      table) the line after ``[END]`` starts with ``drivelash``.

    Anything else (and anything unreadable) is not ours.
    """
    return output_command(path) is not None


def output_command(path: str | Path) -> str | None:
    """The command that wrote the drivelash output at ``path``; ``None`` if it is not ours.

    The command is read from the signature ``drivelash <version> <command>`` (JSON
    ``generator``, HTML meta tag, PNG/PDF/SVG metadata; :func:`signature`) or from the
    marker file of a directory. ``''``: a drivelash output that does not record its
    command (an empty directory, a recording, a CNC table, a text table, or a file of the
    kinds above written before the command was recorded). See :func:`is_own_output`.
    """
    p = Path(path)
    try:
        if p.is_dir():
            marker = p / DIRECTORY_MARKER
            if marker.is_file():
                try:
                    doc = json.loads(marker.read_text(encoding="utf-8"))
                except (ValueError, UnicodeDecodeError):
                    return ""
                return str(doc.get("command") or "") if isinstance(doc, dict) else ""
            return "" if not any(p.iterdir()) else None
        if not p.is_file():
            return None
        ext = p.suffix.lower()
        sig: str | None = None
        if ext == ".json":
            m = re.match(rb'\s*\{\s*"generator"\s*:\s*"(drivelash[^"]*)"', _head(p, 512))
            sig = m[1].decode("utf-8", "replace") if m else None
        elif ext in (".html", ".htm"):
            m = re.search(rb'<meta name="generator" content="(drivelash[^"]*)"', _head(p))
            sig = m[1].decode("utf-8", "replace") if m else None
        elif ext == ".png":
            sig = _png_signature(p)
        elif ext == ".pdf":
            sig = _pdf_signature(p)
        elif ext == ".svg":
            m = re.search(rb"<dc:creator>\s*<cc:Agent>\s*<dc:title>(drivelash[^<]*)<", _head(p))
            sig = m[1].decode("utf-8", "replace") if m else None
        elif ext in _RECORDING_KINDS:
            return _recording_owner(p, ext)
        else:
            return "" if _unrecorded_own(p, ext) else None
        return None if sig is None else _command_in(sig)
    except OSError:
        return None


def _unrecorded_own(p: Path, ext: str) -> bool:
    """Signature tests of the kinds that do not record the command (see :func:`is_own_output`)."""
    if ext in (".toml", ".txt"):
        return _first_line(p).startswith(b"# drivelash")
    if ext == ".md":
        return _first_line(p).startswith(b"<!-- drivelash")
    if ext == ".ini":  # a SINUMERIK init program starts with its header %_N_…_INI
        lines = _head(p, 512).split(b"\n", 2)
        first, second = lines[0].strip(), (lines[1].strip() if len(lines) > 1 else b"")
        return first.startswith(b"; drivelash") or (
            first.startswith(b"%_N_") and second.startswith(b"; drivelash")
        )
    if ext == ".com":
        return _com_signed(p)
    return False


def _recording_owner(p: Path, ext: str) -> str | None:
    """:func:`output_command` of a recording (``write_trace``): its metadata's ``generator``."""
    if ext in (".parquet", ".pq"):
        return _recording_command(_parquet_meta(p))
    if ext in (".h5", ".hdf5", ".hdf"):
        return _recording_command(_hdf5_meta(p))
    if ext == ".mat":
        return _recording_command(_mat_meta(p))
    first = _first_line(p)  # .csv: a recording's meta line, or a text table's signature
    if first.startswith(b"# drivelash.meta "):
        return _recording_command(first[len(b"# drivelash.meta ") :].decode("utf-8", "replace"))
    return "" if first.startswith(b"# drivelash") else None


def _stamp_html(stage: Path, command: str) -> None:
    """Record ``command`` in the generator meta tag of a staged HTML report."""
    text = stage.read_text(encoding="utf-8")
    old = f'<meta name="generator" content="{GENERATOR}">'
    head = text[:_HEAD]
    if old in head:
        new = f'<meta name="generator" content="{GENERATOR} {command}">'
        stage.write_text(head.replace(old, new, 1) + text[_HEAD:], encoding="utf-8")


# =========================================================================== renames
_RENAME_EXCHANGE = 2
_AT_FDCWD = -100
_renameat2: Any = None
_renameat2_checked = False


def _exchange(a: Path, b: Path) -> bool:
    """Swap two paths atomically with Linux ``renameat2(RENAME_EXCHANGE)``; False if unsupported."""
    global _renameat2, _renameat2_checked
    if not _renameat2_checked:
        _renameat2_checked = True
        try:
            libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
            fn = libc.renameat2
            fn.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
            fn.restype = ctypes.c_int
            _renameat2 = fn
        except (OSError, AttributeError):
            _renameat2 = None
    if _renameat2 is None:
        return False
    rc = _renameat2(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE)
    if rc == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.EINVAL, errno.ENOSYS, errno.EOPNOTSUPP, errno.EXDEV, errno.EPERM):
        return False
    raise OSError(err, os.strerror(err), str(b))


def _fsync_path(path: Path) -> None:
    with contextlib.suppress(OSError):
        fd = os.open(path, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


@contextlib.contextmanager
def _locked(dirs: Iterable[Path]) -> Iterator[None]:
    """Exclusive ``flock`` on each directory (sorted order), signals held off meanwhile."""
    block = threading.current_thread() is threading.main_thread()
    sigs = {signal.SIGTERM, signal.SIGINT}
    if block:
        old_mask = signal.pthread_sigmask(signal.SIG_BLOCK, sigs)
    fds: list[int] = []
    try:
        for d in sorted({str(x) for x in dirs}):
            fd = os.open(d, os.O_RDONLY | os.O_DIRECTORY)
            fds.append(fd)
            fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        for fd in reversed(fds):
            with contextlib.suppress(OSError):
                fcntl.flock(fd, fcntl.LOCK_UN)
            os.close(fd)
        if block:
            signal.pthread_sigmask(signal.SIG_SETMASK, old_mask)


@contextlib.contextmanager
def atomic_write(path: str | Path) -> Iterator[Path]:
    """Library helper: yield a temporary name next to ``path``; rename it into place on success.

    No ownership checks (a library call replaces its target, as ``pandas.to_parquet``
    does); commands use :class:`Outputs`. On an exception the temporary file is removed.
    """
    dst = through_link(Path(os.path.abspath(path)))
    tmp = _new_stage(dst, directory=False)
    try:
        yield tmp
        with _locked([dst.parent]):
            os.replace(tmp, dst)
    except BaseException:
        _remove(tmp)
        raise


@contextlib.contextmanager
def write_target(path: str | Path) -> Iterator[Path]:
    """The path a writer writes ``path``'s content to: the one choice of every file writer.

    A staging path of :class:`Outputs` is written directly (the command's commit puts it in
    place); any other path (a library call) through :func:`atomic_write`, so that a failed
    write leaves an existing file as it was. The writer picks the format by
    :func:`final_suffix` of ``path``, not of the yielded name.
    """
    p = Path(path)
    if is_staging_path(p):
        yield p
        return
    with atomic_write(p) as tmp:
        yield tmp


# =========================================================================== Outputs
@dataclass
class _Target:
    path: Path  # absolute; parent resolved, last component as given (a live link: its target)
    option: str
    directory: bool
    stage: Path | None = None
    shown: str = ""  # the path as the user gave it (for messages)


def _attempt(fn: Any) -> bool:
    """Call ``fn()``; whether it ran without an ``OSError`` (an undo step of a failed commit)."""
    try:
        fn()
    except OSError:
        return False
    return True


def _display(path: str | Path) -> str:
    return os.fspath(path)


def _one_line(text: str) -> str:
    return " ".join(text.split())


def _resolved(p: Path) -> Path:
    return Path(os.path.realpath(p))


def _inside(child: Path, parent: Path) -> bool:
    return child != parent and child.is_relative_to(parent)


class Outputs:
    """The outputs of one command: validated up front, staged, committed as a set.

    Parameters
    ----------
    command : str or None
        Command name (recorded in the marker file of output directories).
    inputs : iterable of path
        Every file or directory the command reads. No output may be one of them, nor lie
        inside an input directory (a model, a campaign).
    force : bool
        Replace existing files/directories that are not drivelash outputs (``--force``).
    allow_inside : iterable of path
        Locations inside an input directory where outputs are allowed (e.g. a model's
        ``evaluation/`` sub-directory).
    """

    def __init__(
        self,
        command: str | None = None,
        *,
        inputs: Iterable[str | Path | None] = (),
        force: bool = False,
        allow_inside: Iterable[str | Path] = (),
    ) -> None:
        self.command = command
        self.force = force
        self.inputs = [Path(p) for p in inputs if p is not None and os.fspath(p) != ""]
        self.allow_inside = [_resolved(Path(p)) for p in allow_inside]
        self._targets: list[_Target] = []
        self._staged_order: list[tuple[_Target, Path]] = []  # (target, stage), in staging order
        self._done = False
        #: After a failed :meth:`commit`: whether every output already renamed was put back.
        self.rolled_back = False

    # ------------------------------------------------------------ context
    def __enter__(self) -> Outputs:
        return self

    def __exit__(self, exc_type: Any, exc: Any, tb: Any) -> None:
        if exc_type is None:
            try:
                self.commit()
            except OSError as e:
                err = self.write_error(e, left_as_they_were=self.rolled_back)
                if err is None:
                    raise
                raise err from e
            return
        self.abort()
        if isinstance(exc, OSError):
            err = self.write_error(exc, left_as_they_were=True)
            if err is not None:
                raise err from exc

    def write_error(self, exc: OSError, *, left_as_they_were: bool = False) -> OutputError | None:
        """The one-line error of an ``OSError`` met while writing an output; None if not one.

        The error is an output's when its file name is a target or a temporary name of this
        set (or lies in a staged directory), or, without a file name of another file, when its ``errno`` is
        one of :data:`WRITE_ERRNOS` (a full disk or quota, a file too large, a read-only or
        failing device): then it names the output staged last, the one being written.

        Parameters
        ----------
        exc : OSError
            The error.
        left_as_they_were : bool
            Add that the existing targets were left as they were (true before the commit).

        Returns
        -------
        OutputError or None
            ``OPTION PATH: cannot write it: REASON``, the path as the user gave it.
        """
        target: _Target | None = None
        names = [f for f in (exc.filename, exc.filename2) if isinstance(f, str | bytes | os.PathLike)]
        for name in names:
            path = Path(os.fsdecode(name))
            for t, stage in self._staged_order:
                m = _STAGE_RE.match(path.name)
                if (
                    path in (stage, t.path)
                    or (m is not None and m["name"] == t.path.name and path.parent == t.path.parent)
                    or (t.directory and _inside(path, stage))
                ):
                    target = t
        if target is None:
            if names or exc.errno not in WRITE_ERRNOS or not self._staged_order:
                return None
            target = self._staged_order[-1][0]
        # the C library's text of the errno: pyarrow and h5py wrap it in long driver messages
        reason = os.strerror(exc.errno) if exc.errno else _one_line(str(exc)) or type(exc).__name__
        tail = "; the existing files were left as they were" if left_as_they_were else ""
        return self._fail(target.option, target.shown or target.path, f"cannot write it: {reason}{tail}")

    # ------------------------------------------------------------ validation
    def _fail(self, option: str, path: str | Path, problem: str) -> OutputError:
        return OutputError(f"{option} {_display(path)}: {problem}")

    def _common(self, path: str | Path, option: str) -> tuple[Path, Path]:
        raw = os.fspath(path)
        if raw.strip() == "":
            raise OutputError(f"{option}: empty path")
        p = Path(raw)
        if _STAGE_RE.match(p.name):
            raise self._fail(option, raw, "name is reserved for drivelash temporary files")
        try:
            return self._checked(p, raw, option)
        except OSError as exc:  # a component too long, a symlink loop, …: os.stat's own error
            raise self._fail(option, raw, os.strerror(exc.errno) if exc.errno else str(exc)) from None

    def _checked(self, p: Path, raw: str, option: str) -> tuple[Path, Path]:
        """The checks of :meth:`_common` that touch the file system."""
        parent = p.parent if str(p.parent) else Path(".")
        if not parent.exists():
            raise self._fail(option, raw, f"directory {_display(parent)} does not exist")
        if not parent.is_dir():
            raise self._fail(option, raw, f"{_display(parent)} is not a directory")
        if not _writable_dir(parent):
            raise self._fail(option, raw, f"directory {_display(parent)} is not writable")
        if p.name not in ("", ".", ".."):
            n, room, name_max = _name_room(parent, p.name)
            if n > room:
                raise self._fail(
                    option,
                    raw,
                    f"file name too long ({n} bytes; at most {room} here: it is"
                    f" first written under a temporary name {STAGE_NAME_OVERHEAD} bytes longer, and the"
                    f" file system allows {name_max})",
                )
        target = _resolved(parent) / p.name
        if p.name in ("", ".", ".."):
            target = _resolved(p)
        elif target.is_symlink() and target.exists():
            # written through the link: the checks above again for where it points
            target = through_link(target)
            real = target.parent
            if not _writable_dir(real):
                raise self._fail(
                    option, raw, f"a symbolic link to {target}, whose directory {real} is not writable"
                )
            n, room, _ = _name_room(real, target.name)
            if n > room:
                raise self._fail(
                    option,
                    raw,
                    f"a symbolic link to {target}, whose name is too long for its temporary name"
                    f" ({n} bytes; at most {room} there)",
                )
        return p, target

    def _check_inputs(self, option: str, raw: Path, target: Path, directory: bool) -> None:
        rt = _resolved(target)
        for q in self.inputs:
            if not q.exists():
                continue
            rq = _resolved(q)
            same = rt == rq
            if not same and target.exists():
                with contextlib.suppress(OSError):
                    same = os.path.samefile(target, q)
            if same:
                raise self._fail(option, raw, "is an input of this command; choose another path")
            allowed = any(rt == a or _inside(rt, a) for a in self.allow_inside)
            if q.is_dir() and _inside(rt, rq) and not allowed:
                raise self._fail(
                    option, raw, f"is inside the input directory {_display(q)}; choose another path"
                )
            if directory and _inside(rq, rt):
                raise self._fail(
                    option, raw, f"contains {_display(q)}, an input of this command; choose another path"
                )
        for t in self._targets:
            rt2 = _resolved(t.path)
            if rt2 == rt:
                raise self._fail(option, raw, f"is also the output of {t.option}; choose another path")
            if t.directory and _inside(rt, rt2):
                raise self._fail(option, raw, f"is inside the output directory of {t.option}")
            if directory and _inside(rt2, rt):
                raise self._fail(option, raw, f"contains the output of {t.option}")

    def _check_existing(self, option: str, raw: Path, target: Path) -> None:
        """An existing target is replaced without ``--force`` only if this command wrote it."""
        if self.force or not (target.exists() or target.is_symlink()):
            return
        what = "directory" if target.is_dir() else "file"
        owner = output_command(target)
        if target.is_symlink() and not target.exists():  # was "an existing file that is not …"
            problem = f"a symbolic link to {os.readlink(target)}, which does not exist"
        elif owner is None:
            problem = f"an existing {what} that is not a drivelash output"
        elif not self.command or owner == self.command:
            return
        elif owner:
            problem = f"an existing {what} written by 'drivelash {owner}', not by this command"
        elif target.is_dir() or target.suffix.lower() not in _RECORDS_COMMAND:
            return  # a kind that never records its command: ours is enough
        else:
            problem = (
                f"an existing drivelash {what} that does not record which command wrote it"
                " (an older drivelash or a library call)"
            )
        raise self._fail(option, raw, f"{problem}; use --force to replace it or choose another path")

    def file(
        self, path: str | Path | None, *, option: str, kinds: Iterable[str] | None = None
    ) -> Path | None:
        """Validate one output file; returns its absolute target path (``None`` passes through).

        Parameters
        ----------
        path : path or None
            The output file as the user gave it.
        option : str
            The command-line option that named it (used in error messages), e.g. ``"--json"``.
        kinds : iterable of str, optional
            Accepted extensions (lower case, with the dot), e.g. :data:`PLOT_EXTENSIONS`.
        """
        if path is None:
            return None
        raw, target = self._common(path, option)
        if kinds is not None:
            kinds = tuple(kinds)
            ext = raw.suffix.lower()
            if ext not in kinds:
                shown = f"'{raw.suffix}'" if raw.suffix else "(none)"
                raise self._fail(option, raw, f"unsupported extension {shown} (use {', '.join(kinds)})")
        if target.is_dir():
            raise self._fail(option, raw, "is a directory; give a file name")
        if target.exists() and not target.is_file():
            raise self._fail(option, raw, "exists and is not a regular file")
        self._check_inputs(option, raw, target, directory=False)
        self._check_existing(option, raw, target)
        self._targets.append(_Target(target, option, directory=False, shown=_display(raw)))
        return target

    def directory(self, path: str | Path | None, *, option: str) -> Path | None:
        """Validate an output directory written as a whole; returns its absolute target path."""
        if path is None:
            return None
        raw, target = self._common(path, option)
        if target.exists() and not target.is_dir():
            raise self._fail(option, raw, "exists and is not a directory")
        cwd = Path.cwd().resolve()
        if target.exists() and (_resolved(target) == cwd or _inside(cwd, _resolved(target))):
            raise self._fail(option, raw, "contains the current directory; choose another path")
        self._check_inputs(option, raw, target, directory=True)
        self._check_existing(option, raw, target)
        self._targets.append(_Target(target, option, directory=True, shown=_display(raw)))
        return target

    # ------------------------------------------------------------ staging
    def _target(self, target: str | Path) -> _Target:
        t = Path(target)
        for x in self._targets:
            if x.path == t:
                return x
        raise ValueError(f"{target} is not a declared output of this command")

    def staging(self, target: str | Path) -> Path:
        """The temporary path to write ``target`` to (created on first call; same path after).

        For a file: an empty hidden file next to the target whose name keeps the target's
        name (:func:`final_suffix` gives its extension). For a directory: an empty hidden
        sibling directory.
        """
        if self._done:
            raise RuntimeError("outputs already committed or aborted")
        t = self._target(target)
        if t.stage is None:
            t.stage = _new_stage(t.path, t.directory)
            self._staged_order.append((t, t.stage))
            if self.command and not t.directory:
                _STAGED_BY[os.fspath(t.stage)] = self.command
        return t.stage

    def staged(self, target: str | Path | None) -> bool:
        """Whether ``target`` has been staged (``None`` → False)."""
        return target is not None and self._target(target).stage is not None

    # ------------------------------------------------------------ commit / abort
    def abort(self) -> None:
        """Remove every staged file/directory; targets stay as they were."""
        self._done = True
        for t in self._targets:
            if t.stage is not None:
                _STAGED_BY.pop(os.fspath(t.stage), None)
                _remove(t.stage)
                t.stage = None

    def _put_in_place(self, t: _Target, old: list[Path]) -> Any:
        """Rename ``t``'s staged output onto its target; returns the callable that undoes it.

        The previous file is kept under a hidden ``….old`` name (a hard link, so the target
        never disappears; a rename where links are not supported), the previous directory
        at the stage name or a ``….old`` name; each is appended to ``old`` (removed after the
        whole set is in place).
        """
        assert t.stage is not None
        stage, path = t.stage, t.path
        aside = stage.with_name(stage.name[: -len(".part")] + ".old")
        if not t.directory:
            if not (path.exists() or path.is_symlink()):
                os.replace(stage, path)
                return lambda: path.unlink()
            try:
                os.link(path, aside, follow_symlinks=False)
                moved = False
            except OSError:
                os.rename(path, aside)  # raises where the target cannot be replaced at all
                moved = True
            try:
                os.replace(stage, path)
            except BaseException:
                if moved:
                    os.replace(aside, path)
                else:
                    _remove(aside)
                raise
            old.append(aside)
            return lambda: os.replace(aside, path)
        if not path.exists():
            os.rename(stage, path)
            return lambda: _remove(path)  # a new directory: nothing was there
        if _exchange(stage, path):
            old.append(stage)  # the previous directory now lives at the stage name

            def swap_back() -> None:
                if not _exchange(stage, path):
                    raise OSError(errno.EIO, "cannot exchange the directories back", os.fspath(path))
                _remove(stage)  # now the new directory

            return swap_back
        os.rename(path, aside)
        try:
            os.rename(stage, path)
        except BaseException:
            os.rename(aside, path)
            raise
        old.append(aside)

        def rename_back() -> None:
            os.rename(path, stage)
            os.rename(aside, path)
            _remove(stage)  # now the new directory

        return rename_back

    def commit(self) -> list[Path]:
        """Put every staged output in place, together; returns the written targets."""
        if self._done:
            return []
        staged = [t for t in self._targets if t.stage is not None]
        old: list[Path] = []
        undo: list[Any] = []  # one callable per output put in place, restoring what was there
        try:
            for t in staged:
                assert t.stage is not None
                if t.directory:
                    marker = {"command": self.command or "", "output": t.option}
                    write_json(t.stage / DIRECTORY_MARKER, marker)
                else:
                    _STAGED_BY.pop(os.fspath(t.stage), None)
                    if self.command and final_suffix(t.path) in (".html", ".htm"):
                        _stamp_html(t.stage, self.command)
                    _fsync_path(t.stage)
            with _locked(t.path.parent for t in staged):
                for t in staged:  # the target may have changed since validation
                    self._check_existing(t.option, t.path, t.path)
                    if t.directory and t.path.exists() and not t.path.is_dir():
                        raise self._fail(t.option, t.path, "exists and is not a directory")
                    if not t.directory and t.path.is_dir():
                        raise self._fail(t.option, t.path, "is a directory; give a file name")
                for t in staged:
                    _sweep_stale(t.path)
                    assert t.stage is not None
                    undo.append(self._put_in_place(t, old))
                    t.stage = None
                for d in {t.path.parent for t in staged}:
                    _fsync_path(d)
        except BaseException:
            # a rename that fails half-way through the set (an immutable or vanished target)
            # puts the outputs already renamed back: the set is all new or all old
            self.rolled_back = all(_attempt(u) for u in reversed(undo))
            self.abort()
            raise
        self._done = True
        for t in staged:
            _WRITTEN[os.fspath(t.path)] = t.shown or os.fspath(t.path)
        for o in old:  # the old copies go last, after every new output is in place
            _remove(o)
        return [t.path for t in staged]
