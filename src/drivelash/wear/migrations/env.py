"""Alembic environment: migrations run on the connection handed over by the Store.

``drivelash.wear.store.Store`` calls ``alembic.command.upgrade(cfg, "head")`` with the open
connection in ``cfg.attributes["connection"]``; there is no ``alembic.ini`` and no URL here.
"""

from __future__ import annotations

from alembic import context

connection = context.config.attributes.get("connection")
if connection is None:  # pragma: no cover - only the Store runs these migrations
    raise RuntimeError("drivelash migrations run through drivelash.wear.store.Store")
context.configure(connection=connection, target_metadata=None, render_as_batch=True)
with context.begin_transaction():
    context.run_migrations()
