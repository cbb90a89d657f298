"""The kind of each axis: ``axis.kind`` ("rotary" or "prismatic").

Revision ID: 0004
Revises: 0003
Create Date: 2026-12-01

A linear (prismatic) axis's estimates, threshold and noise are lengths in m, a rotary axis's
angles in rad (:mod:`drivelash.io.load`). The trend's absolute constants and every view depend on
which (``drivelash.wear.trend.trend_scale``, :func:`drivelash.units.gap_unit`): a store read with
``--db`` alone has no fleet file to tell. Ingest writes the kind its fleet file resolves
(``AxisSpec.kind``: the drive file's ``[columns]``). NULL for axes written before: read as
"rotary", as every store was until this revision; the next ingest writes the kind.
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0004"
down_revision = "0003"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.add_column("axis", sa.Column("kind", sa.String(16), nullable=True))


def downgrade() -> None:
    with op.batch_alter_table("axis") as batch:
        batch.drop_column("kind")
