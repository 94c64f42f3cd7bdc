"""The shared base under both servers, the clinic gateway and the burn center: storage (the SQLite database and
its migrations runner, records and the audit chain, blobs, default folders), accounts and the web plumbing."""

__version__ = "0.1.0"
