"""The durable analysis queue, its workers and their files."""
