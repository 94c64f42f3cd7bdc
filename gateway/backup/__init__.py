"""Encrypted, consistent backups of a clinic gateway's whole state, and their verified restore (docs/backup.md).

snapshot: what the state is and one consistent copy of it; archive: the tar inside; stream: the file format and
secretstream encryption; crypto: passphrase and recipient keys; writer: `burnedge backup` and rotation;
restore: `burnedge restore`; restored_config: the configuration a restore writes.
"""
