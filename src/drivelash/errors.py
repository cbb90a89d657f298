"""The toolkit's own exception types.

Every error a user can provoke with bad input (a file, a column, a parameter, a
configuration key) is a :class:`DrivelashError`, whose message is one line naming
where the problem is. The CLI turns these into a one-line message and exit code 2.
"""

from __future__ import annotations


class DrivelashError(Exception):
    """Base class of all user-facing errors (bad input, bad parameters, bad files)."""


class ParameterError(DrivelashError, ValueError):
    """An invalid physical parameter or gain.

    Parameters
    ----------
    owner : str
        Name of the parameter set, e.g. ``"DrivetrainParams"``.
    field : str
        Name of the offending field, e.g. ``"J_m"``.
    problem : str
        What is wrong, in plain language.
    """

    def __init__(self, owner: str, field: str, problem: str) -> None:
        self.owner = owner
        self.field = field
        self.problem = problem
        super().__init__(f"{owner}.{field}: {problem}")


class DataRows:
    """Where the data rows of a file are, for messages: the one location helper.

    A reader keeps one per file (``RawTable.rows``, ``ColumnSource.rows``); every message that
    points at a data row names it with :meth:`where`. This base class names a row of a file
    without lines (Parquet, HDF5, MAT) or of data in memory: ``data row N (1-based)``, N
    counting the data rows from 1 (the first row below the header is data row 1). A text file's
    reader keeps :class:`drivelash.io.formats.CsvLines`, which names the line an editor shows.
    """

    def line(self, row: int) -> int | None:
        """The 1-based line of the file holding 0-based data row ``row``; None without lines."""
        return None

    def where(self, row: int) -> str:
        """0-based data row ``row`` as the user finds it: ``line N`` or ``data row N (1-based)``."""
        line = self.line(int(row))
        return f"line {line}" if line is not None else f"data row {int(row) + 1} (1-based)"

    def taken(self, index: object) -> DataRows:
        """The rows of data that kept the rows ``index`` (0-based, of these rows) of this data:
        row ``i`` there is row ``index[i]`` here (a recording sampled down or resampled)."""
        return _TakenRows(self, index)


class _TakenRows(DataRows):
    """:meth:`DataRows.taken`: rows of a subset (or a resampled grid) of another's rows."""

    def __init__(self, base: DataRows, index: object) -> None:
        self._base, self._index = base, index

    def _row(self, row: int) -> int:
        index = self._index
        return int(index[row]) if 0 <= row < len(index) else row  # type: ignore[index,arg-type]

    def line(self, row: int) -> int | None:
        return self._base.line(self._row(row))

    def where(self, row: int) -> str:
        return self._base.where(self._row(row))


#: rows of a file without lines or of data in memory (``data row N (1-based)``)
NO_LINES = DataRows()


class DataError(DrivelashError, ValueError):
    """A problem with a recording: file, column, row.

    Parameters
    ----------
    message : str
        The problem in plain language.
    path : str, optional
        File the data came from.
    column : str, optional
        Offending column.
    row : int, optional
        First bad row (0-based data row: the first row below the header is row 0).
    rows : DataRows, optional
        Where the file's data rows are (the reader's ``rows``): the message names ``row`` as
        :meth:`DataRows.where` does — ``line N`` of a text file, else ``data row N (1-based)``.
    """

    def __init__(
        self,
        message: str,
        path: str | None = None,
        column: str | None = None,
        row: int | None = None,
        rows: DataRows | None = None,
    ) -> None:
        self.path = path
        self.column = column
        self.row = row
        self.problem = message
        where = []
        if path:
            where.append(str(path))
        if column:
            where.append(f"column '{column}'")
        if row is not None:
            where.append((rows or NO_LINES).where(row))
        prefix = ": ".join([", ".join(where)]) + ": " if where else ""
        super().__init__(prefix + message)


class ConfigError(DrivelashError, ValueError):
    """A problem in a TOML configuration file (missing, unknown or invalid key)."""


class OutputError(DrivelashError, ValueError):
    """A problem with an output path: ``OPTION PATH: problem`` (see :mod:`drivelash.io.outputs`)."""


class ResourceError(DrivelashError, ValueError):
    """A request that would exceed the memory or time budget (see :mod:`drivelash.io.budget`)."""
