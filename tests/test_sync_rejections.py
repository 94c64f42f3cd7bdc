"""Bad input at a real burn-center process over Zenoh: each is refused with its reason, recorded, nothing partial
is stored, and a good bundle still goes through afterwards."""

from __future__ import annotations

import hashlib
import json
import uuid
from pathlib import Path

import msgspec
import pytest
import zenoh

from harness.center_bundles import make_bundle
from harness.sites import CENTER, CLINIC, Sites, cli
from schemas.transfer import (
    AnnounceReply,
    CommitReply,
    SiteIdentity,
    SiteRole,
    TransferManifest,
)
from sync.keys import SiteKeys, init_keys, load_keys
from sync.wire import request
from sync.zenoh_link import Keys

pytestmark = pytest.mark.server


class Clinic:
    """A clinic speaking the protocol by hand, to send what a well-behaved gateway never would."""

    def __init__(self, session, keys: SiteKeys):
        self.session, self.keys = session, keys
        self.link = Keys("burnedge", CENTER)

    def ask(self, key: str, payload: bytes) -> bytes:
        return request(self.session, key, payload, 10)

    def announce(self, envelope: bytes) -> AnnounceReply:
        return msgspec.msgpack.decode(self.ask(self.link.announce(self.keys.site_id), envelope), type=AnnounceReply)

    def chunk(self, bundle_id: str, index: int, sha: str, data: bytes) -> bytes:
        return self.ask(self.link.chunk(self.keys.site_id, bundle_id, index, sha), data)

    def send_all(self, bundle_id: str, sealed) -> CommitReply:
        for i, (ref, data) in enumerate(zip(sealed.refs, sealed.chunks, strict=True)):
            self.chunk(bundle_id, i, ref.sha256, data)
        return msgspec.msgpack.decode(self.ask(self.link.commit(self.keys.site_id, bundle_id), b""), type=CommitReply)


def refused(call, code: str) -> str:
    from schemas.errors import TransferRejected

    with pytest.raises(TransferRejected) as caught:
        call()
    assert caught.value.code == code, caught.value.detail
    return caught.value.detail


def test_every_bad_input_is_refused_and_nothing_partial_is_stored(tmp_path: Path, center_database: str):
    sites = Sites(tmp_path, center_database=center_database)
    sites.set_up()
    # A second clinic, enrolled then revoked; and a stranger nobody enrolled.
    revoked = init_keys(tmp_path / "revoked-keys", "clinic-revoked", SiteRole.clinic, "Revoked clinic")
    cli("peers", "enrol", "--center", str(tmp_path / "revoked-keys" / "site.pub.json"), env=sites.center.env)
    cli("peers", "revoke", "--center", "clinic-revoked", "--reason", "laptop stolen", env=sites.center.env)
    stranger = init_keys(tmp_path / "stranger-keys", CLINIC, SiteRole.clinic, "Impostor")  # same name, other keys
    keys = load_keys(tmp_path / "burnedge-keys")
    center = msgspec.json.decode((tmp_path / "burnedge-central-keys" / "site.pub.json").read_bytes(), type=SiteIdentity)
    sites.center.start()
    conf = zenoh.Config()
    for key, value in (
        ("mode", "client"),
        ("connect/endpoints", [f"tcp/127.0.0.1:{sites.zenoh_port}"]),
        ("scouting/multicast/enabled", False),
        ("transport/shared_memory/enabled", False),
    ):
        conf.insert_json5(key, json.dumps(value))
    try:
        with zenoh.open(conf) as session:
            clinic = Clinic(session, keys)
            encounter = str(uuid.uuid4())

            # Garbage on the key expression, and garbage as a manifest.
            refused(lambda: clinic.ask(f"burnedge/{CENTER}/nonsense/x", b"\x00\xff"), "garbage")
            refused(lambda: clinic.ask(f"burnedge/{CENTER}/chunk/{CLINIC}/not-an-id/0/ab", b"x"), "garbage")
            refused(lambda: clinic.announce(b"\x93\x01\x02garbage"), "garbage")

            # Signed by an unknown key (claiming to be the clinic), and by a revoked site.
            _, forged, _ = make_bundle(stranger, center, encounter, 1)
            refused(lambda: clinic.announce(forged), "bad-signature")
            nobody = init_keys(tmp_path / "nobody-keys", "clinic-nobody", SiteRole.clinic, "Never enrolled")
            _, unknown, _ = make_bundle(nobody, center, encounter, 1)
            refused(lambda: Clinic(session, nobody).announce(unknown), "unknown-site")
            _, from_revoked, _ = make_bundle(revoked, center, encounter, 1)
            detail = refused(lambda: Clinic(session, revoked).announce(from_revoked), "revoked-site")
            assert "laptop stolen" in detail

            # A chunk for a bundle never announced.
            bundle_id, envelope, sealed = make_bundle(keys, center, encounter, 1)
            refused(lambda: clinic.chunk(bundle_id, 0, sealed.refs[0].sha256, sealed.chunks[0]), "unannounced")

            # Announced: a tampered chunk, a truncated chunk, a chunk under another chunk's hash.
            assert clinic.announce(envelope).status == "send"
            tampered = bytearray(sealed.chunks[1])
            tampered[40] ^= 0x01
            refused(lambda: clinic.chunk(bundle_id, 1, sealed.refs[1].sha256, bytes(tampered)), "chunk-mismatch")
            refused(lambda: clinic.chunk(bundle_id, 1, sealed.refs[1].sha256, sealed.chunks[1][:-7]), "chunk-size")
            refused(lambda: clinic.chunk(bundle_id, 1, sealed.refs[2].sha256, sealed.chunks[1]), "chunk-mismatch")
            commit = msgspec.msgpack.decode(clinic.ask(clinic.link.commit(CLINIC, bundle_id), b""), type=CommitReply)
            assert commit.status == "missing" and commit.missing == list(range(len(sealed.chunks)))

            # The genuine chunks still complete the bundle; a re-send of it is answered, not stored again.
            stored = clinic.send_all(bundle_id, sealed)
            assert stored.status == "stored"
            again = clinic.announce(envelope)
            assert again.status == "stored" and again.receipt == stored.receipt

            # A replayed old version once a newer one is stored, and another bundle claiming a stored version.
            newer_id, newer, newer_sealed = make_bundle(keys, center, encounter, 2)
            clinic.announce(newer)
            assert clinic.send_all(newer_id, newer_sealed).status == "stored"
            _, old_again, _ = make_bundle(keys, center, encounter, 1)
            refused(lambda: clinic.announce(old_again), "replayed")

            # A bundle whose chunks are signed but do not decrypt (a broken sender): refused whole at commit.
            broken_id, broken_env, broken = make_bundle(keys, center, str(uuid.uuid4()), 1)
            other = make_bundle(keys, center, str(uuid.uuid4()), 1)[2]
            swapped_refs = [other.refs[0], *broken.refs[1:]]
            announcement = msgspec.msgpack.decode(
                msgspec.msgpack.decode(broken_env, type=dict)["body"], type=TransferManifest
            )
            bad_env = msgspec.msgpack.encode(
                keys.sign("manifest", msgspec.structs.replace(announcement, chunks=swapped_refs))
            )
            clinic.announce(bad_env)
            chunks = [other.chunks[0], *broken.chunks[1:]]
            for i, data in enumerate(chunks):
                clinic.chunk(broken_id, i, hashlib.sha256(data).hexdigest(), data)
            refused(lambda: clinic.ask(clinic.link.commit(CLINIC, broken_id), b""), "chunk-forged")
            # Asked again (its answer lost on the way), or announced again: told the same reason, not "never announced".
            again = refused(lambda: clinic.ask(clinic.link.commit(CLINIC, broken_id), b""), "chunk-forged")
            assert "was refused at" in again
            refused(lambda: clinic.announce(bad_env), "chunk-forged")
    finally:
        sites.center.stop()

    assert sorted(r[0] for r in sites.center.rows("SELECT version FROM bundles")) == [1, 2]
    assert sites.center.rows("SELECT COUNT(*) FROM incoming") == [(0,)]
    codes = {r[0] for r in sites.center.rows("SELECT code FROM rejections")}
    assert {
        "garbage",
        "bad-signature",
        "unknown-site",
        "revoked-site",
        "unannounced",
        "chunk-mismatch",
        "chunk-size",
        "replayed",
        "chunk-forged",
    } <= codes
    assert not any(p.is_file() for p in (tmp_path / "burnedge-central-store" / "incoming").rglob("*"))
