"""The rate the estimator ran at: ``estimate.estimate_rate_hz``.

Revision ID: 0002
Revises: 0001
Create Date: 2026-11-27

Since this revision the tracker estimates δ on every k-th sample of a recording sampled faster
than the fleet's ``estimate_rate_hz`` (default 1 kHz, docs/scaling.md). The column holds the
rate the estimator saw [Hz]; NULL for the rows written before (every sample was used: the
recording's ``sample_rate_hz``).
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0002"
down_revision = "0001"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.add_column("estimate", sa.Column("estimate_rate_hz", sa.Float, nullable=True))


def downgrade() -> None:
    with op.batch_alter_table("estimate") as batch:
        batch.drop_column("estimate_rate_hz")
