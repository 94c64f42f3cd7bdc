"""Phones: the change feed a paired phone pulls and the batched push it sends, through the records' own service
and checks (pairing and devices are base/accounts')."""
