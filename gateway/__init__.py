"""The clinic gateway: the Litestar HTTP API, the services behind it and their SQLite storage."""

__version__ = "0.1.0"
