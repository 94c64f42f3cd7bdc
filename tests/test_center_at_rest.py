"""Cases at rest at the center, on both backends: kept as the clinic's sealed chunks, so neither the database nor
the store folder holds a photo's bytes; read back decrypted for a consultant; a chunk damaged on disk before the
commit is asked for again, one damaged after it is refused on read, and a bundle sealed wrongly by its clinic is
rejected."""

from __future__ import annotations

import hashlib
import os
import uuid
from pathlib import Path

import msgspec
import pytest

from base.folders import center_store_dir
from center.cases import CaseService
from center.receiver import Receiver
from harness.center_bundles import make_bundle
from schemas.errors import StorageError, TransferRejected
from schemas.transfer import ChunkRef, SignedEnvelope, TransferManifest
from tests.conftest import CONSULTANT
from tests.test_center_database import enrolled_center

PHOTO = bytes(range(256)) * 64  # what harness.center_bundles packs as photos/a.jpg


@pytest.fixture
def center(tmp_path: Path, center_database: str):
    central, db, keys, clinic = enrolled_center(tmp_path, center_database)
    receiver = Receiver(db, central, keys, center_store_dir(central))
    yield central, db, keys, clinic, receiver
    db.close()


def send(receiver: Receiver, clinic, envelope: bytes, bundle_id: str, sealed) -> None:
    assert receiver.announce(clinic.site_id, envelope).status == "send"
    for i, (ref, data) in enumerate(zip(sealed.refs, sealed.chunks, strict=True)):
        receiver.chunk(clinic.site_id, bundle_id, i, ref.sha256, data)


def every_file(folder: Path) -> list[Path]:
    return [p for p in folder.rglob("*") if p.is_file()]


def test_a_stored_case_is_sealed_at_rest_and_read_back_for_a_consultant(center, tmp_path):
    central, db, keys, clinic, receiver = center
    bundle_id, envelope, sealed = make_bundle(clinic, keys.identity, str(uuid.uuid4()), 1, chunk_size=1000)
    send(receiver, clinic, envelope, bundle_id, sealed)
    assert receiver.commit(clinic.site_id, bundle_id).status == "stored"

    store = Path(central.store_dir)
    files = every_file(store)
    kept = store / "bundles" / clinic.site_id / bundle_id / "sealed.bin"
    assert files == [kept] and kept.read_bytes() == b"".join(sealed.chunks)  # as the clinic sealed it
    assert PHOTO[:256] not in kept.read_bytes()
    if not central.database.startswith("postgresql://"):
        assert PHOTO[:256] not in Path(central.database).read_bytes()
    service = CaseService(db, keys, store)
    assert service.part(CONSULTANT, clinic.site_id, bundle_id, "photos/a.jpg") == (PHOTO, "image/jpeg")
    record, media_type = service.part(CONSULTANT, clinic.site_id, bundle_id, "record.json")
    assert msgspec.json.decode(record)["encounter"] and media_type == "application/json"

    data = bytearray(kept.read_bytes())
    data[10 * len(sealed.chunks[0]) + 40] ^= 1  # chunk 10: inside the photo
    kept.write_bytes(bytes(data))
    with pytest.raises(StorageError, match="damaged"):
        service.part(CONSULTANT, clinic.site_id, bundle_id, "photos/a.jpg")
    assert service.part(CONSULTANT, clinic.site_id, bundle_id, "record.json")[0] == record  # in chunk 0


def test_a_staged_chunk_damaged_before_the_commit_is_asked_for_again(center):
    central, db, keys, clinic, receiver = center
    bundle_id, envelope, sealed = make_bundle(clinic, keys.identity, str(uuid.uuid4()), 1, chunk_size=1000)
    send(receiver, clinic, envelope, bundle_id, sealed)
    staged = Path(central.store_dir) / "incoming" / clinic.site_id / bundle_id / "000003.chunk"
    data = bytearray(staged.read_bytes())
    data[-1] ^= 1  # the power went before this write reached the disk whole
    staged.write_bytes(bytes(data))

    reply = receiver.commit(clinic.site_id, bundle_id)
    assert (reply.status, reply.missing) == ("missing", [3])
    receiver.chunk(clinic.site_id, bundle_id, 3, sealed.refs[3].sha256, sealed.chunks[3])
    assert receiver.commit(clinic.site_id, bundle_id).status == "stored"


def test_a_bundle_its_clinic_sealed_wrongly_is_rejected_and_nothing_of_it_kept(center):
    central, db, keys, clinic, receiver = center
    bundle_id, envelope, sealed = make_bundle(clinic, keys.identity, str(uuid.uuid4()), 1, chunk_size=1000)
    chunks = list(sealed.chunks)
    chunks[2] = os.urandom(len(chunks[2]))  # listed with its own sha256, so it arrives "intact"
    announced = msgspec.msgpack.decode(
        msgspec.msgpack.decode(envelope, type=SignedEnvelope).body, type=TransferManifest
    )
    refs = [ChunkRef(sha256=hashlib.sha256(c).hexdigest(), size=len(c)) for c in chunks]
    resigned = msgspec.msgpack.encode(clinic.sign("manifest", msgspec.structs.replace(announced, chunks=refs)))
    assert receiver.announce(clinic.site_id, resigned).status == "send"
    for i, (ref, data) in enumerate(zip(refs, chunks, strict=True)):
        receiver.chunk(clinic.site_id, bundle_id, i, ref.sha256, data)

    with pytest.raises(TransferRejected) as refused:
        receiver.commit(clinic.site_id, bundle_id)
    assert refused.value.code == "chunk-forged"
    assert every_file(Path(central.store_dir)) == []
    assert db.connection().execute("SELECT COUNT(*) FROM incoming").fetchone()[0] == 0
