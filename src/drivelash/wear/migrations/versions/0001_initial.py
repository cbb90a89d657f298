"""Initial schema: axis, recording, estimate, measurement, alarm.

Revision ID: 0001
Revises:
Create Date: 2026-01-01

Times are UTC without a zone (SQLite has none); angles in rad at the load.
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0001"
down_revision = None
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "axis",
        sa.Column("id", sa.Integer, primary_key=True, autoincrement=True),
        sa.Column("name", sa.String(200), nullable=False, unique=True),
        sa.Column("machine", sa.String(100), nullable=False),
        sa.Column("drive_path", sa.Text, nullable=True),
        sa.Column("drive_hash", sa.String(64), nullable=True),
        sa.Column("threshold_rad", sa.Float, nullable=True),
        sa.Column("transmission_mm_per_rad", sa.Float, nullable=True),
        sa.Column("horizon_days", sa.Float, nullable=False, server_default="30"),
        sa.Column("not_excited_alarm", sa.Integer, nullable=False, server_default="5"),
        sa.Column("updated_at", sa.DateTime, nullable=False),
    )
    op.create_table(
        "recording",
        sa.Column("id", sa.Integer, primary_key=True, autoincrement=True),
        sa.Column("axis_id", sa.Integer, sa.ForeignKey("axis.id", ondelete="CASCADE"), nullable=False),
        sa.Column("content_hash", sa.String(64), nullable=False),
        sa.Column("path", sa.Text, nullable=False),
        sa.Column("size_bytes", sa.BigInteger, nullable=False),
        sa.Column("mtime_ns", sa.BigInteger, nullable=False),
        sa.Column("start_time", sa.DateTime, nullable=True),
        sa.Column("duration_s", sa.Float, nullable=True),
        sa.Column("sample_rate_hz", sa.Float, nullable=True),
        sa.Column("samples", sa.BigInteger, nullable=True),
        sa.UniqueConstraint("axis_id", "content_hash", name="uq_recording_axis_content"),
    )
    op.create_index("ix_recording_axis_path", "recording", ["axis_id", "path"])
    op.create_table(
        "estimate",
        sa.Column("id", sa.Integer, primary_key=True, autoincrement=True),
        sa.Column(
            "recording_id", sa.Integer, sa.ForeignKey("recording.id", ondelete="CASCADE"), nullable=False
        ),
        sa.Column("axis_id", sa.Integer, sa.ForeignKey("axis.id", ondelete="CASCADE"), nullable=False),
        sa.Column("method", sa.String(32), nullable=False),
        sa.Column("code_version", sa.String(64), nullable=False),
        sa.Column("config_hash", sa.String(64), nullable=False),
        sa.Column("status", sa.String(8), nullable=False),
        sa.Column("reason", sa.Text, nullable=True),
        sa.Column("delta", sa.Float, nullable=True),
        sa.Column("delta1_estimate", sa.Float, nullable=True),
        sa.Column("delta_std", sa.Float, nullable=True),
        sa.Column("excitation_ok", sa.Boolean, nullable=True),
        sa.Column("converged", sa.Boolean, nullable=True),
        sa.Column("runtime_s", sa.Float, nullable=True),
        sa.Column("created_at", sa.DateTime, nullable=False),
        sa.UniqueConstraint(
            "recording_id", "method", "config_hash", "code_version", name="uq_estimate_identity"
        ),
    )
    op.create_index("ix_estimate_axis", "estimate", ["axis_id"])
    op.create_table(
        "measurement",
        sa.Column("id", sa.Integer, primary_key=True, autoincrement=True),
        sa.Column("axis_id", sa.Integer, sa.ForeignKey("axis.id", ondelete="CASCADE"), nullable=False),
        sa.Column("source", sa.String(32), nullable=False),
        sa.Column("key", sa.String(128), nullable=False),
        sa.Column("time", sa.DateTime, nullable=False),
        sa.Column("value", sa.Float, nullable=False),
        sa.Column("std", sa.Float, nullable=True),
        sa.Column("unit", sa.String(16), nullable=False),
        sa.Column("value_rad", sa.Float, nullable=True),
        sa.Column("std_rad", sa.Float, nullable=True),
        sa.Column("reference", sa.Text, nullable=True),
        sa.Column("details", sa.Text, nullable=True),
        sa.Column("created_at", sa.DateTime, nullable=False),
        sa.UniqueConstraint("axis_id", "source", "key", name="uq_measurement_identity"),
    )
    op.create_table(
        "alarm",
        sa.Column("id", sa.Integer, primary_key=True, autoincrement=True),
        sa.Column("axis_id", sa.Integer, sa.ForeignKey("axis.id", ondelete="CASCADE"), nullable=False),
        sa.Column("kind", sa.String(32), nullable=False),
        sa.Column("key", sa.String(128), nullable=False),
        sa.Column("message", sa.Text, nullable=False),
        sa.Column("data_time", sa.DateTime, nullable=True),
        sa.Column("raised_at", sa.DateTime, nullable=False),
        sa.Column("cleared_at", sa.DateTime, nullable=True),
        sa.UniqueConstraint("axis_id", "kind", "key", name="uq_alarm_identity"),
    )


def downgrade() -> None:
    op.drop_table("alarm")
    op.drop_table("measurement")
    op.drop_index("ix_estimate_axis", table_name="estimate")
    op.drop_table("estimate")
    op.drop_index("ix_recording_axis_path", table_name="recording")
    op.drop_table("recording")
    op.drop_table("axis")
