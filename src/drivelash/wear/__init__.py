"""Wear tracking of backlash across a fleet (issue 10).

* :mod:`~drivelash.wear.fleet` — the inventory ``fleet.toml`` (pydantic-validated);
* :mod:`~drivelash.wear.store` — the history store (SQLAlchemy 2.x, Alembic migrations shipped
  in ``wear/migrations``; SQLite in WAL mode by default, PostgreSQL for a shared store);
* :mod:`~drivelash.wear.estimate` — one recording → one estimate row (the only adapter to
  the estimator);
* :mod:`~drivelash.wear.ingest` — workers compute (local processes or Dask), one writer commits;
* :mod:`~drivelash.wear.trend` — change points (ruptures), outliers, growth models
  (statsmodels/scipy), forecast of the threshold crossing with a 90 % interval;
* :mod:`~drivelash.wear.alarms` — threshold, forecast, jump and not-excited alarms.
"""

from drivelash.wear.fleet import AxisSpec, Fleet, load_fleet
from drivelash.wear.ingest import IngestReport, ingest
from drivelash.wear.store import EstimateRow, Store, StoreError

__all__ = ["AxisSpec", "EstimateRow", "Fleet", "IngestReport", "Store", "StoreError", "ingest", "load_fleet"]
