"""jobs: when the running attempt was claimed (attempt_started_at), so that every ended attempt's history entry has
its start, also one a cancel, the lease policy or a hand-back ends

Revision ID: 0007
Revises: 0006
Create Date: 2026-11-30
"""

import sqlalchemy as sa
from alembic import op

revision = "0007"
down_revision = "0006"
branch_labels = None
depends_on = None


def upgrade() -> None:
    # a nullable column: a plain ADD COLUMN on SQLite and PostgreSQL alike, no table copied
    op.add_column("jobs", sa.Column("attempt_started_at", sa.DateTime(timezone=True), nullable=True))


def downgrade() -> None:
    with op.batch_alter_table("jobs") as batch:
        batch.drop_column("attempt_started_at")
