"""jobs: the completion webhook (callback URL, delivery state, attempts, next attempt, last error)

Revision ID: 0004
Revises: 0003
Create Date: 2026-11-24
"""

import sqlalchemy as sa
from alembic import op

revision = "0004"
down_revision = "0003"
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table("jobs") as batch:
        batch.add_column(sa.Column("callback_url", sa.Text(), nullable=True))
        batch.add_column(sa.Column("callback_state", sa.String(length=16), nullable=True))
        batch.add_column(sa.Column("callback_attempts", sa.Integer(), nullable=False, server_default="0"))
        batch.add_column(sa.Column("callback_next_at", sa.DateTime(timezone=True), nullable=True))
        batch.add_column(sa.Column("callback_error", sa.Text(), nullable=True))
    op.create_index("ix_jobs_callback_due", "jobs", ["callback_state", "callback_next_at"])


def downgrade() -> None:
    op.drop_index("ix_jobs_callback_due", table_name="jobs")
    with op.batch_alter_table("jobs") as batch:
        for name in ("callback_error", "callback_next_at", "callback_attempts", "callback_state", "callback_url"):
            batch.drop_column(name)
