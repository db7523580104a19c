"""Secure runs across machines: TLS links, a join credential, access control.

``swarmactors world --secure DIR`` generates (or reuses) in DIR:

* ``ca.pem`` / ``ca.key`` - a private certificate authority;
* ``world.pem`` / ``world.key`` - the world's TLS certificate, valid for the
  names given (``world``, ``localhost``, ``127.0.0.1`` and any ``--tls-name``);
* ``users.txt`` - the Zenoh user/password dictionary of the world (router);
* ``host.credential`` - ``user:password`` that robot hosts need to connect at
  all, shared by identical replicas.

Hosts get ``ca.pem`` and ``host.credential`` (``swarmactors robots --secure DIR``).

Modes are set explicitly, whatever the umask: certificates 0644, keys and credentials 0600, a directory these
functions create 0700.

``cluster_files(DIR)`` adds ``cluster.pem`` / ``cluster.key``: one certificate signed by the same CA that the
Dask scheduler, its workers and the submitting client all present (mutual TLS, ``--cluster tls://…``).
The world's Zenoh access-control rules let that credential only query
``world/join`` and ``up/*``, publish under ``up/*`` and subscribe under
``down/*`` (and hold a liveliness token) - never publish on ``down/*``,
``state``, ``events`` or ``control``. Because replicas share one credential,
each host additionally seals its uplinks with its own key (transport.auth).
"""

from __future__ import annotations

import datetime
import ipaddress
import os
import secrets
import tempfile
from dataclasses import dataclass
from pathlib import Path

HOST_USER = "robot-host"
PUBLIC_MODE = 0o644  # certificates: hosts and workers need ca.pem; a certificate holds no secret
SECRET_MODE = 0o600  # private keys, users.txt, host.credential: the owner only
DIRECTORY_MODE = 0o700  # a directory these functions create


def _make_directory(directory: Path) -> None:
    """Create ``directory`` with mode 0700 whatever the umask; an existing one is left as it is."""
    if not directory.is_dir():
        directory.mkdir(parents=True, mode=DIRECTORY_MODE)
        os.chmod(directory, DIRECTORY_MODE)  # mkdir's mode is masked by the umask; chmod's is not


def _write(path: Path, data: bytes, mode: int) -> None:
    """Write ``path`` with exactly ``mode`` (whatever the umask), by rename: never readable by others, never half.

    The temporary file has a unique name (``mkstemp``: created 0600), so two processes writing the same
    directory at once each rename a whole file.
    """
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.")
    try:
        with os.fdopen(fd, "wb") as f:
            os.fchmod(fd, mode)
            f.write(data)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


@dataclass(frozen=True)
class Security:
    """What one process needs for a secure Zenoh session."""

    role: str  # "world" or "host"
    directory: Path

    @property
    def ca(self) -> Path:
        return self.directory / "ca.pem"

    def zenoh_settings(self, run_id: str) -> dict[str, object]:
        """Zenoh config keys (slash-separated) for this role."""
        d = self.directory
        if self.role == "world":
            return {
                "transport/link/tls/listen_certificate": str(d / "world.pem"),
                "transport/link/tls/listen_private_key": str(d / "world.key"),
                "transport/link/tls/root_ca_certificate": str(self.ca),
                "transport/auth/usrpwd/dictionary_file": str(d / "users.txt"),
                "access_control": access_control(run_id),
            }
        user, password = read_credential(d / "host.credential")
        return {
            "transport/link/tls/root_ca_certificate": str(self.ca),
            "transport/auth/usrpwd/user": user,
            "transport/auth/usrpwd/password": password,
        }


def access_control(run_id: str) -> dict:
    """Zenoh ACL: what the robot-host credential may do on the world's router; everything else is denied."""
    p = f"swarmactors/{run_id}"
    rules = [
        {"id": "host-requests", "permission": "allow", "flows": ["ingress"], "messages": ["query"],
         "key_exprs": [f"{p}/world/join", f"{p}/up/*"]},
        {"id": "host-uplink", "permission": "allow", "flows": ["ingress"], "messages": ["put"],
         "key_exprs": [f"{p}/up/*"]},
        {"id": "host-downlink-subscription", "permission": "allow", "flows": ["ingress"],
         "messages": ["declare_subscriber"], "key_exprs": [f"{p}/down/*"]},
        {"id": "host-liveliness", "permission": "allow", "flows": ["ingress"], "messages": ["liveliness_token"],
         "key_exprs": [f"@swarmactors/{run_id}/alive/*"]},
        {"id": "world-to-host", "permission": "allow", "flows": ["egress"], "messages": ["put"],
         "key_exprs": [f"{p}/down/*"]},
        {"id": "world-replies", "permission": "allow", "flows": ["egress"], "messages": ["reply"],
         "key_exprs": [f"{p}/world/join", f"{p}/up/*"]},
        {"id": "world-declarations", "permission": "allow", "flows": ["egress"],
         "messages": ["declare_queryable", "declare_subscriber"], "key_exprs": [f"{p}/world/join", f"{p}/up/*"]},
    ]
    return {
        "enabled": True,
        "default_permission": "deny",
        "rules": rules,
        "subjects": [{"id": "robot-hosts", "usernames": [HOST_USER]}],
        "policies": [{"rules": [r["id"] for r in rules], "subjects": ["robot-hosts"]}],
    }


def read_credential(path: Path) -> tuple[str, str]:
    try:
        user, _, password = path.read_text().strip().partition(":")
    except OSError as exc:
        raise ValueError(f"{path}: cannot read the host credential: {exc.strerror}") from None
    if not user or not password:
        raise ValueError(f"{path}: expected one line user:password")
    return user, password


def _alt_names(names: list[str]) -> list:
    """A certificate's subject alternative names: IP addresses as such, anything else as a DNS name."""
    from cryptography import x509

    alt = []
    for name in names:
        try:
            alt.append(x509.IPAddress(ipaddress.ip_address(name)))
        except ValueError:
            alt.append(x509.DNSName(name))
    return alt


def ensure_files(directory: Path, names: list[str] = ()) -> Path:
    """Create the CA, the world's certificate and the credential in ``directory`` unless present."""
    from cryptography import x509
    from cryptography.hazmat.primitives import hashes, serialization
    from cryptography.hazmat.primitives.asymmetric import ec
    from cryptography.x509.oid import NameOID

    _make_directory(directory)
    needed = ["ca.pem", "ca.key", "world.pem", "world.key", "users.txt", "host.credential"]
    if all((directory / n).exists() for n in needed):
        return directory
    now = datetime.datetime.now(datetime.timezone.utc)
    valid = (now - datetime.timedelta(minutes=5), now + datetime.timedelta(days=365))

    def pem(cert) -> bytes:
        return cert.public_bytes(serialization.Encoding.PEM)

    def private(key) -> bytes:
        return key.private_bytes(serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8,
                                 serialization.NoEncryption())

    ca_key = ec.generate_private_key(ec.SECP256R1())
    ca_name = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, "swarmactors run CA")])
    ca = (x509.CertificateBuilder().subject_name(ca_name).issuer_name(ca_name).public_key(ca_key.public_key())
          .serial_number(x509.random_serial_number()).not_valid_before(valid[0]).not_valid_after(valid[1])
          .add_extension(x509.BasicConstraints(ca=True, path_length=0), critical=True)
          .sign(ca_key, hashes.SHA256()))
    alt = _alt_names(["world", "localhost", "127.0.0.1", *names])
    world_key = ec.generate_private_key(ec.SECP256R1())
    world = (x509.CertificateBuilder()
             .subject_name(x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, "world")])).issuer_name(ca_name)
             .public_key(world_key.public_key()).serial_number(x509.random_serial_number())
             .not_valid_before(valid[0]).not_valid_after(valid[1])
             .add_extension(x509.SubjectAlternativeName(alt), critical=False)
             .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
             .sign(ca_key, hashes.SHA256()))
    password = secrets.token_urlsafe(24)
    files = {"ca.pem": pem(ca), "ca.key": private(ca_key), "world.pem": pem(world), "world.key": private(world_key),
             "users.txt": f"{HOST_USER}:{password}\n".encode(), "host.credential": f"{HOST_USER}:{password}\n".encode()}
    for name, data in files.items():
        _write(directory / name, data, PUBLIC_MODE if name.endswith(".pem") else SECRET_MODE)
    return directory


CLUSTER_NAMES = ("scheduler", "localhost", "127.0.0.1")


def cluster_files(directory: Path, names: list[str] = ()) -> Path:
    """The CA (``ensure_files``) and ``cluster.pem``/``cluster.key`` for a Dask cluster's mutual TLS, unless present.

    One certificate for the scheduler, the workers and the client (Dask checks the CA, not host names); valid
    for ``CLUSTER_NAMES`` and ``names``. Written key last and by rename, so a reader waiting for ``cluster.key``
    never sees half a pair.
    """
    from cryptography import x509
    from cryptography.hazmat.primitives import hashes, serialization
    from cryptography.hazmat.primitives.asymmetric import ec
    from cryptography.x509.oid import NameOID

    ensure_files(directory)
    if (directory / "cluster.pem").exists() and (directory / "cluster.key").exists():
        return directory
    ca = x509.load_pem_x509_certificate((directory / "ca.pem").read_bytes())
    ca_key = serialization.load_pem_private_key((directory / "ca.key").read_bytes(), password=None)
    now = datetime.datetime.now(datetime.timezone.utc)
    alt = _alt_names([*CLUSTER_NAMES, *names])
    key = ec.generate_private_key(ec.SECP256R1())
    cert = (x509.CertificateBuilder()
            .subject_name(x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, "swarmactors cluster")]))
            .issuer_name(ca.subject).public_key(key.public_key()).serial_number(x509.random_serial_number())
            .not_valid_before(now - datetime.timedelta(minutes=5)).not_valid_after(now + datetime.timedelta(days=365))
            .add_extension(x509.SubjectAlternativeName(alt), critical=False)
            .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
            .sign(ca_key, hashes.SHA256()))
    _write(directory / "cluster.pem", cert.public_bytes(serialization.Encoding.PEM), PUBLIC_MODE)
    _write(directory / "cluster.key", key.private_bytes(serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8,
                                                        serialization.NoEncryption()), SECRET_MODE)
    return directory
