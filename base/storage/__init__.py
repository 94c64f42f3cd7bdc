"""The SQLite file, its records and audit chain, and the files kept beside it."""
