"""msgspec Structs: the one definition of every message burnedge sends, stores or syncs.

HTTP bodies, SQLite rows, sync payloads and result files are all encoded from and
decoded into the Structs defined here; nothing else defines a message's shape.
"""
