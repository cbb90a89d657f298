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
        First bad row (0-based data row).
    """

    def __init__(
        self,
        message: str,
        path: str | None = None,
        column: str | None = None,
        row: int | None = None,
    ) -> None:
        self.path = path
        self.column = column
        self.row = row
        where = []
        if path:
            where.append(str(path))
        if column:
            where.append(f"column '{column}'")
        if row is not None:
            where.append(f"row {row}")
        prefix = ": ".join([", ".join(where)]) + ": " if where else ""
        super().__init__(prefix + message)


class ConfigError(DrivelashError, ValueError):
    """A problem in a TOML configuration file (missing, unknown or invalid key)."""


class OutputError(DrivelashError, ValueError):
    """A problem with an output path: ``OPTION PATH: problem`` (see :mod:`drivelash.io.outputs`)."""


class ResourceError(DrivelashError, ValueError):
    """A request that would exceed the memory or time budget (see :mod:`drivelash.io.budget`)."""
