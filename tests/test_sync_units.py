"""The pieces of store-and-forward on their own: keys, sealing, the bundle container, stale transfers."""

from __future__ import annotations

import datetime as dt
import os
import time
from pathlib import Path

import msgspec
import pytest

from harness.center_bundles import SUMMARY
from schemas.errors import InvalidInput, TransferRejected
from schemas.transfer import SiteRole
from sync import bundle
from sync.keys import check_identity, fingerprint, init_keys, load_keys
from sync.sealing import OVERHEAD, open_chunks, seal, seal_stream, unseal_key


def test_keys_are_kept_private_and_their_identity_is_self_signed(tmp_path: Path):
    keys = init_keys(tmp_path, "clinic-a", SiteRole.clinic, "Clinic A")
    assert (tmp_path / "site.key").stat().st_mode & 0o777 == 0o600
    assert load_keys(tmp_path).identity == keys.identity
    check_identity(keys.identity)
    other = init_keys(tmp_path / "b", "clinic-b", SiteRole.clinic, "Clinic B")
    swapped = msgspec.structs.replace(keys.identity, box_key=other.identity.box_key)  # someone else's box key
    with pytest.raises(InvalidInput, match="not valid"):
        check_identity(swapped)
    assert fingerprint(keys.identity) != fingerprint(swapped)
    with pytest.raises(InvalidInput, match="already exists"):
        init_keys(tmp_path, "clinic-a", SiteRole.clinic, "Clinic A")


def test_sealed_chunks_open_only_for_the_recipient_in_their_place(tmp_path: Path):
    center = init_keys(tmp_path / "c", "center", SiteRole.center, "Center")
    stranger = init_keys(tmp_path / "s", "stranger", SiteRole.center, "Stranger")
    plain = bytes(range(256)) * 100
    sealed = seal(plain, bytes(center.box.public_key), "bundle-1", 4096)
    key = unseal_key(sealed.sealed_key, center.box)
    assert b"".join(open_chunks(key, "bundle-1", sealed.chunks, len(sealed.chunks))) == plain
    with pytest.raises(TransferRejected) as wrong:
        unseal_key(sealed.sealed_key, stranger.box)
    assert wrong.value.code == "wrong-recipient"
    swapped = [sealed.chunks[1], sealed.chunks[0], *sealed.chunks[2:]]
    with pytest.raises(TransferRejected) as moved:
        b"".join(open_chunks(key, "bundle-1", swapped, len(swapped)))
    assert moved.value.code == "chunk-forged"
    with pytest.raises(TransferRejected):  # the same chunks presented as another bundle's
        b"".join(open_chunks(key, "bundle-2", sealed.chunks, len(sealed.chunks)))


@pytest.mark.parametrize(
    ("split", "chunk_size"),
    [([0], 16), ([16], 16), ([5, 27], 16), ([1, 0, 31, 1], 16), ([50, 0, 50], 7), ([5], 16)],
)
def test_pieces_sealed_as_they_come_open_to_the_same_bytes_in_full_chunks(tmp_path: Path, split, chunk_size):
    center = init_keys(tmp_path / "c", "center", SiteRole.center, "Center")
    plain = bytes(range(256))[: sum(split)]
    pieces = [plain[sum(split[:i]) : sum(split[: i + 1])] for i in range(len(split))]
    sealed_key, chunks = seal_stream(pieces, len(plain), bytes(center.box.public_key), "bundle-1", chunk_size)
    chunks = list(chunks)
    assert len(chunks) == max(1, -(-len(plain) // chunk_size))
    assert all(len(c) == chunk_size + OVERHEAD for c in chunks[:-1])
    key = unseal_key(sealed_key, center.box)
    assert b"".join(open_chunks(key, "bundle-1", chunks, len(chunks))) == plain
    with pytest.raises(ValueError, match="not the 3"):
        list(seal_stream([b"abc"], 10, bytes(center.box.public_key), "bundle-1", 4)[1])


def test_the_container_checks_every_part_against_its_manifest():
    from schemas.transfer import BundleManifest

    parts = [bundle.PartData("record.json", b"{}"), bundle.PartData("photos/a.jpg", b"\xff\xd8 jpeg bytes")]
    manifest = BundleManifest(
        bundle_id="0192f3b4-6a8e-7c3d-9b1a-2f4e5d6c7b8a",
        site_id="clinic-a",
        patient_id="0192f3b4-6a8e-7c3d-9b1a-2f4e5d6c7b8b",
        encounter_id="0192f3b4-6a8e-7c3d-9b1a-2f4e5d6c7b8c",
        version=1,
        supersedes=None,
        created_at="2026-11-22",
        created_by="clin",
        summary=SUMMARY,
        parts=[p.described for p in parts],
    )
    packed = bundle.pack(manifest, parts)
    for piece in (1, 5, 64, len(packed)):  # as decrypted chunks of any size arrive
        assert checked(packed, piece) == (manifest, packed.index(b"{}", 12 + 8))
    with pytest.raises(TransferRejected) as altered:
        checked(packed[:-3] + b"XXX")
    assert altered.value.code == "part-mismatch"
    with pytest.raises(TransferRejected) as extra:
        checked(packed + b"more")
    assert extra.value.code == "bad-bundle"
    with pytest.raises(TransferRejected, match="ends before"):
        checked(packed[:-1])
    with pytest.raises(TransferRejected, match="not a burnedge bundle"):
        checked(b"PK\x03\x04" + packed[4:])
    evil = msgspec.structs.replace(
        manifest, parts=[msgspec.structs.replace(manifest.parts[0], name="../../etc/x"), manifest.parts[1]]
    )
    with pytest.raises(TransferRejected, match="safe relative path"):
        checked(bundle.pack(evil, [bundle.PartData("../../etc/x", b"{}"), parts[1]]))


def checked(container: bytes, piece: int = 7):
    check = bundle.ContainerCheck()
    for start in range(0, len(container), piece):
        check.feed(container[start : start + piece])
    return check.finish()


def test_unfinished_transfers_are_dropped_after_the_stale_period(tmp_path: Path):
    from center.app import open_center_db
    from center.receiver import Receiver
    from schemas.config import CentralConfig

    central = CentralConfig(database=str(tmp_path / "center.sqlite3"))
    db = open_center_db(central)
    keys = init_keys(tmp_path / "keys", "center", SiteRole.center, "Center")
    receiver = Receiver(db, central, keys, tmp_path / "store")
    old = (dt.datetime.now(dt.UTC) - dt.timedelta(days=20)).isoformat()
    with db.write() as conn:
        for bundle_id, at in (
            ("0192f3b4-6a8e-7c3d-9b1a-000000000001", old),
            ("0192f3b4-6a8e-7c3d-9b1a-000000000002", dt.datetime.now(dt.UTC).isoformat()),
        ):
            conn.execute(
                "INSERT INTO incoming VALUES (?,?,?,?,?,?,?,?)", ("clinic-a", bundle_id, b"", "0" * 64, "e", 1, 1, at)
            )
            (tmp_path / "store" / "incoming" / "clinic-a" / bundle_id).mkdir(parents=True)
    killed = tmp_path / "store" / "bundles" / "clinic-a" / "0192f3b4-6a8e-7c3d-9b1a-000000000003"
    killed.mkdir(parents=True)
    for name, days in (("sealed.bin.aaaa.tmp", 20), ("sealed.bin.bbbb.tmp", 0), ("sealed.bin", 20)):
        (killed / name).write_bytes(b"x")
        os.utime(killed / name, (time.time() - days * 86400,) * 2)
    assert receiver.drop_stale(14) == 1
    assert sorted(p.name for p in killed.iterdir()) == ["sealed.bin", "sealed.bin.bbbb.tmp"]
    left = [r[0] for r in db.connection().execute("SELECT bundle_id FROM incoming")]
    assert left == ["0192f3b4-6a8e-7c3d-9b1a-000000000002"]
    assert not (tmp_path / "store" / "incoming" / "clinic-a" / "0192f3b4-6a8e-7c3d-9b1a-000000000001").exists()
    db.close()
