"""Replication: the phones' change feed and push, and (later) Zenoh store-and-forward to the burn center."""
