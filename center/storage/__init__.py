"""The burn center's SQL: one module per table family, each with a typed API; the schema in migrations.py."""
