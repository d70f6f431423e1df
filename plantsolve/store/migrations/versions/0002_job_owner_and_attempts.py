"""jobs: owner (tenancy), attempts history, idempotency keys namespaced by owner

Revision ID: 0002
Revises: 0001
Create Date: 2026-11-24
"""

import sqlalchemy as sa
from alembic import op

revision = "0002"
down_revision = "0001"
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table("jobs") as batch:
        batch.add_column(sa.Column("owner", sa.String(64), nullable=False, server_default=""))
        batch.add_column(sa.Column("attempts", sa.JSON(), nullable=True))
        batch.alter_column("idempotency_key", type_=sa.String(320), existing_type=sa.String(255), existing_nullable=True)
    op.create_index("ix_jobs_owner_created", "jobs", ["owner", "created_at", "id"])


def downgrade() -> None:
    op.drop_index("ix_jobs_owner_created", table_name="jobs")
    with op.batch_alter_table("jobs") as batch:
        batch.alter_column("idempotency_key", type_=sa.String(255), existing_type=sa.String(320), existing_nullable=True)
        batch.drop_column("attempts")
        batch.drop_column("owner")
