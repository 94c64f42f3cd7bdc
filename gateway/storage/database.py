"""The gateway's SQLite file: the shared database, migrated by the gateway's own migration set."""

from __future__ import annotations

from sqlite_utils import Migrations

from base.storage import database
from gateway.storage.migrations import migrations as gateway_migrations


class Database(database.Database):
    """The gateway's database; `migrate()` with no argument applies the gateway's migrations."""

    def migrate(self, migrations: Migrations = gateway_migrations) -> list[str]:
        return super().migrate(migrations)
