"""Alembic migrations of the wear history store (run by :class:`drivelash.wear.store.Store`)."""
