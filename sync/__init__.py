"""Replication to the burn center: case bundles sealed end to end, the clinic's outbox and sender over Zenoh, the
center's advice mailbox, peer enrolment and keys, and the audit anchors the center signs. (The phones' change feed
is the gateway's: gateway/phones/sync.py.)"""
