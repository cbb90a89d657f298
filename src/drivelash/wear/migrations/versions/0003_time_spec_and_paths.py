"""How each recording was dated, and every path a recording's content was seen under.

Revision ID: 0003
Revises: 0002
Create Date: 2026-11-27

* ``recording.time_spec_hash``: SHA-256 of the axis's ``time`` specification (fleet.toml) the
  recording's ``start_time`` was found with. When the specification changes, ingest re-dates
  the recording (``wear.ingest.redate``). NULL for rows written before: dated by an unknown
  specification, re-dated once by the next ingest.
* ``recording_path``: (recording, path, size, mtime) of every file whose content is the
  recording — a copy ("x - Kopie.csv") is skipped on the next run by its file facts instead
  of being re-estimated every time (the recording's own ``path`` stays the first one seen).
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0003"
down_revision = "0002"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.add_column("recording", sa.Column("time_spec_hash", sa.String(64), nullable=True))
    op.create_table(
        "recording_path",
        sa.Column("id", sa.Integer, primary_key=True),
        sa.Column(
            "recording_id", sa.Integer, sa.ForeignKey("recording.id", ondelete="CASCADE"), nullable=False
        ),
        sa.Column("path", sa.Text, nullable=False),
        sa.Column("size_bytes", sa.BigInteger, nullable=False),
        sa.Column("mtime_ns", sa.BigInteger, nullable=False),
        sa.UniqueConstraint("recording_id", "path", name="uq_recording_path"),
    )


def downgrade() -> None:
    op.drop_table("recording_path")
    with op.batch_alter_table("recording") as batch:
        batch.drop_column("time_spec_hash")
