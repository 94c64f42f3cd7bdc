"""Transfers to the burn center: queueing an encounter's case bundle (the record, the report, the analyses'
files), its status, and the consultants' advice that comes back; the controller beside its service. The sealing
and the Zenoh link are sync/'s."""
