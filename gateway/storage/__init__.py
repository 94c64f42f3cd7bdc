"""SQLite storage: one database file in WAL mode, migrated with sqlite-utils."""
