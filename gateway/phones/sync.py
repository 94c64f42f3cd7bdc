"""Offline-first phone sync: pull a change feed by cursor, push a batch of queued mutations.

Push is idempotent per mutation_id: the outcome of every mutation is stored with the
change it made, in the same savepoint, so a phone that retries a batch (because the
answer was lost on bad Wi-Fi) gets the same answers and nothing is applied twice.
Each mutation stands alone: a conflict or a rejected item does not undo the others.
"""

from __future__ import annotations

import hashlib

import msgspec

from base.accounts.permissions import Principal, readable_kinds, require_delete, require_write
from base.storage import records as store
from gateway.records.service import RecordService
from schemas.errors import BurnedgeError, Conflict, InvalidInput, VersionMismatch
from schemas.sync import ChangesPage, Mutation, MutationOp, MutationResult, MutationStatus, PushResponse


class PhoneSync:
    def __init__(self, records: RecordService, page_max: int):
        self.records = records
        self.page_max = page_max

    def changes(self, principal: Principal, since: int, limit: int) -> ChangesPage:
        if since < 0:
            raise InvalidInput("since must be 0 or a cursor returned by an earlier page")
        limit = max(1, min(limit, self.page_max))
        kinds = readable_kinds(principal)
        conn = self.records.db.connection()
        page = store.changes_since(conn, since, limit + 1, kinds) if kinds else []
        has_more = len(page) > limit
        page = page[:limit]
        next_cursor = page[-1].meta.seq if page else since
        return ChangesPage(changes=page, next_cursor=next_cursor, has_more=has_more)

    def push(self, principal: Principal, mutations: list[Mutation]) -> PushResponse:
        results: list[MutationResult] = []
        db = self.records.db
        with db.write() as conn:
            for mutation in mutations:
                fingerprint = _fingerprint(mutation)
                stored = store.find_applied_mutation(conn, mutation.mutation_id)
                try:
                    if stored is not None:
                        results.append(self._replay(principal, mutation, fingerprint, stored))
                        continue
                    with db.savepoint(conn):
                        result = self._apply(conn, principal, mutation)
                        store.remember_applied_mutation(conn, result, fingerprint, principal.user_id)
                except BurnedgeError as exc:
                    # Not remembered: a retry re-evaluates it (its parent may have arrived meanwhile).
                    result = _failure(mutation, exc)
                results.append(result)
        counts = {s: sum(r.status is s for r in results) for s in MutationStatus}
        return PushResponse(
            results=results,
            applied=counts[MutationStatus.applied],
            conflicts=counts[MutationStatus.conflict],
            rejected=counts[MutationStatus.rejected],
        )

    def _replay(
        self, principal: Principal, m: Mutation, fingerprint: str, stored: store.AppliedMutation
    ) -> MutationResult:
        """The stored outcome of a mutation seen before, if it really is the same mutation."""
        if stored.fingerprint != fingerprint:
            raise InvalidInput(
                f"mutation_id {m.mutation_id} was already used for a different change: give each change its own id"
            )
        if m.op is MutationOp.delete:
            require_delete(principal, m.kind)
        else:
            require_write(principal, m.kind)
        return msgspec.structs.replace(stored.result, replayed=True)

    def _apply(self, conn, principal: Principal, m: Mutation) -> MutationResult:
        svc = self.records
        if m.op is MutationOp.create:
            outcome = svc.create_in(conn, principal, m.kind, m.id, _require_data(m))
        elif m.op is MutationOp.update:
            outcome = svc.update_in(conn, principal, m.kind, m.id, _require_data(m), _require_base(m))
        else:
            outcome = svc.delete_in(conn, principal, m.kind, m.id, _require_base(m), m.reason or "")
        return MutationResult(
            mutation_id=m.mutation_id, status=MutationStatus.applied, version=outcome.record.meta.version
        )


def _fingerprint(m: Mutation) -> str:
    """What makes two pushes the same mutation: everything but the phone's clock."""
    return hashlib.sha256(msgspec.json.encode(msgspec.structs.replace(m, client_time=None))).hexdigest()


def _require_data(m: Mutation) -> dict:
    if m.data is None:
        raise InvalidInput(f"{m.op.value} of {m.kind.value} {m.id} needs data")
    return m.data


def _require_base(m: Mutation) -> int:
    if m.base_version is None:
        raise InvalidInput(f"{m.op.value} of {m.kind.value} {m.id} needs base_version (the version the phone edited)")
    return m.base_version


def _failure(m: Mutation, exc: BurnedgeError) -> MutationResult:
    if isinstance(exc, (VersionMismatch, Conflict)):
        return MutationResult(
            mutation_id=m.mutation_id, status=MutationStatus.conflict, current=exc.current, error=exc.detail
        )
    return MutationResult(mutation_id=m.mutation_id, status=MutationStatus.rejected, error=exc.detail)
