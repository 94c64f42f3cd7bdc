"""HTTPS on the clinic's Wi-Fi: the gateway's own certificate authority and the server certificate it issues.

A phone reaches the gateway at a LAN address, where browsers allow the camera and service workers only over
HTTPS. No public authority certifies a LAN address, so on first start the gateway makes its own authority (kept in
its keys folder, so backups carry it) and issues itself a certificate for its host name and addresses. A phone
trusts the authority once (GET /ca.crt, steps at /phone-setup) and every later certificate follows. The server
certificate is issued again when it nears expiry or when the gateway's addresses changed (DHCP), at start and
daily. What this protects and what it does not: docs/security.md.

Keys and certificates come from `cryptography` (OpenSSL); nothing here is a cryptographic primitive of our own.
"""

from __future__ import annotations

import datetime as dt
import ipaddress
import os
import socket
from dataclasses import dataclass
from pathlib import Path

import psutil
from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID

from base.network import is_loopback, lan_address
from base.storage.durable import replace_atomically
from schemas.config import GatewayConfig

CA_KEY, CA_CERT = "gateway-ca.key.pem", "gateway-ca.cert.pem"
SERVER_KEY, SERVER_CERT = "gateway-tls.key.pem", "gateway-tls.cert.pem"
CA_YEARS = 10
SERVER_DAYS = 397
"""Within the 398 days browsers and iOS accept for a server certificate."""
RENEW_DAYS = 30
"""A server certificate with less left than this is issued again."""


@dataclass(frozen=True)
class ServerCertificate:
    cert: Path
    key: Path
    names: list[str]
    addresses: list[str]
    not_after: dt.datetime


def https_wanted(gateway: GatewayConfig) -> bool:
    """Whether the gateway serves HTTPS: [gateway] https on, or auto while it listens beyond loopback."""
    return gateway.https == "on" or (gateway.https == "auto" and not is_loopback(gateway.host))


def _now() -> dt.datetime:
    return dt.datetime.now(dt.UTC)


def _write_private(path: Path, data: bytes) -> None:
    replace_atomically(path, data)
    os.chmod(path, 0o600)


def _new_key() -> ec.EllipticCurvePrivateKey:
    return ec.generate_private_key(ec.SECP256R1())


def _pem_key(key: ec.EllipticCurvePrivateKey) -> bytes:
    return key.private_bytes(
        serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8, serialization.NoEncryption()
    )


def ensure_ca(folder: Path, site_name: str) -> x509.Certificate:
    """The gateway's authority, made on first use and kept (key readable by the gateway's user only)."""
    cert_path = folder / CA_CERT
    if cert_path.exists() and (folder / CA_KEY).exists():
        return x509.load_pem_x509_certificate(cert_path.read_bytes())
    folder.mkdir(parents=True, exist_ok=True)
    key = _new_key()
    name = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, f"burnedge gateway CA ({site_name})"[:64])])
    now = _now()
    cert = (
        x509.CertificateBuilder()
        .subject_name(name)
        .issuer_name(name)
        .public_key(key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(now - dt.timedelta(minutes=5))
        .not_valid_after(now + dt.timedelta(days=365 * CA_YEARS))
        .add_extension(x509.BasicConstraints(ca=True, path_length=0), critical=True)
        .add_extension(
            x509.KeyUsage(True, False, False, False, False, True, True, False, False), critical=True
        )  # digital signature, certificate and CRL signing
        .add_extension(x509.SubjectKeyIdentifier.from_public_key(key.public_key()), critical=False)
        .sign(key, hashes.SHA256())
    )
    _write_private(folder / CA_KEY, _pem_key(key))
    replace_atomically(cert_path, cert.public_bytes(serialization.Encoding.PEM))
    return cert


def fingerprint(cert: x509.Certificate) -> str:
    """SHA-256 of the certificate, as phones show it (colon-separated hex)."""
    return cert.fingerprint(hashes.SHA256()).hex(":").upper()


def local_names(extra: list[str]) -> tuple[list[str], list[str]]:
    """(DNS names, IP addresses) the gateway answers at: its host name (and NAME.local), every address of every
    network interface (link-local ones aside: they change with the interface), and `extra` from the
    configuration."""
    host = socket.gethostname()
    names = {host, f"{host}.local", "localhost"}
    addresses = {"127.0.0.1", "::1"}
    for interface in psutil.net_if_addrs().values():
        for entry in interface:
            if entry.family in (socket.AF_INET, socket.AF_INET6):
                address = ipaddress.ip_address(entry.address.split("%")[0])
                if not address.is_link_local:
                    addresses.add(str(address))
    found = lan_address()
    if found:
        addresses.add(found)
    for item in extra:
        try:
            addresses.add(str(ipaddress.ip_address(item)))
        except ValueError:
            names.add(item)
    return sorted(names), sorted(addresses)


def server_certificate(folder: Path, site_name: str, extra: list[str]) -> ServerCertificate:
    """The gateway's server certificate, issued again when missing, near expiry or not naming every address."""
    names, addresses = local_names(extra)
    current = _current(folder)
    if current is not None and _still_good(current, names, addresses):
        return current
    ca_cert = ensure_ca(folder, site_name)
    ca_key = serialization.load_pem_private_key((folder / CA_KEY).read_bytes(), password=None)
    key = _new_key()
    now = _now()
    alt = [x509.DNSName(n) for n in names] + [x509.IPAddress(ipaddress.ip_address(a)) for a in addresses]
    cert = (
        x509.CertificateBuilder()
        .subject_name(x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, names[0][:64])]))
        .issuer_name(ca_cert.subject)
        .public_key(key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(now - dt.timedelta(minutes=5))
        .not_valid_after(now + dt.timedelta(days=SERVER_DAYS))
        .add_extension(x509.SubjectAlternativeName(alt), critical=False)
        .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
        .add_extension(x509.ExtendedKeyUsage([ExtendedKeyUsageOID.SERVER_AUTH]), critical=False)
        .add_extension(x509.AuthorityKeyIdentifier.from_issuer_public_key(ca_cert.public_key()), critical=False)
        .sign(ca_key, hashes.SHA256())
    )
    _write_private(folder / SERVER_KEY, _pem_key(key))
    chain = cert.public_bytes(serialization.Encoding.PEM) + ca_cert.public_bytes(serialization.Encoding.PEM)
    replace_atomically(folder / SERVER_CERT, chain)
    return ServerCertificate(folder / SERVER_CERT, folder / SERVER_KEY, names, addresses, cert.not_valid_after_utc)


def _current(folder: Path) -> ServerCertificate | None:
    cert_path, key_path = folder / SERVER_CERT, folder / SERVER_KEY
    if not (cert_path.exists() and key_path.exists()):
        return None
    cert = x509.load_pem_x509_certificate(cert_path.read_bytes())
    alt = cert.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
    names = sorted(alt.get_values_for_type(x509.DNSName))
    addresses = sorted(str(a) for a in alt.get_values_for_type(x509.IPAddress))
    return ServerCertificate(cert_path, key_path, names, addresses, cert.not_valid_after_utc)


def _still_good(current: ServerCertificate, names: list[str], addresses: list[str]) -> bool:
    fresh = current.not_after - _now() > dt.timedelta(days=RENEW_DAYS)
    return fresh and set(names) <= set(current.names) and set(addresses) <= set(current.addresses)
