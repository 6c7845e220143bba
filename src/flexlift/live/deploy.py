"""A real lift's broker: the Mosquitto configuration flexlift writes for it
(docs/reference/live.md#the-lifts-broker): one account per role, each password stored hashed,
and an access-control list under which every client may publish only its own topics.

The roles (user names) and what each may do, for the lift ``<lift>``
(topics of docs/reference/messages.md):

=============  =====================================  ====================================
user           may publish                             may receive
=============  =====================================  ====================================
``master``     ``flexlift/<lift>/command/#``           ``flexlift/<lift>/sensor/#``
``rig``        ``flexlift/<lift>/sensor/#``            ``flexlift/<lift>/command/#``
``<bag>``      ``flexlift/<lift>/sensor/<bag>/#``      ``flexlift/<lift>/command/<bag>/#``
``hull``       ``flexlift/<lift>/sensor/hull/#``       nothing
=============  =====================================  ====================================

Only ``master`` (``flexlift live``) can move a valve; a bag's sensor node cannot speak for
another bag, nor command anything; an anonymous client or a wrong password is refused. The
passwords are made here (:func:`new_password`) and stored as Mosquitto 2's PBKDF2-SHA512
hashes (``$7$``, the format of ``mosquitto_passwd``); the clear ones go to one file per
account, readable by its owner only, to be handed to that account's machine.
"""

from __future__ import annotations

import base64
import hashlib
import re
import secrets
from typing import NamedTuple

from flexlift.errors import InputError
from flexlift.live.messages import HULL

#: Mosquitto 2's password hash: PBKDF2 with HMAC-SHA512 ("$7$"), its default iterations and
#: salt length (mosquitto_passwd's own)
HASH_ID, ITERATIONS, SALT_BYTES = 7, 101, 12
#: the two roles of flexlift's own programs
MASTER, RIG = "master", "rig"
#: a user name Mosquitto's password file and ACL can hold: a topic level, no ``:`` or space
_USER = re.compile(r"^[A-Za-z0-9_.-]{1,64}$")
#: a system user, a listening address (an IP address or a host name)
_SYSTEM_USER = re.compile(r"^[a-z_][a-z0-9_-]{0,31}$")
_ADDRESS = re.compile(r"^[A-Za-z0-9.:-]{1,253}$")


def check_setting(field: str, value: str, kind: str) -> str:
    """``value`` if it may stand in Mosquitto's configuration as ``kind`` ("user",
    "address" or "path": no line break, nothing Mosquitto would read as a second setting);
    InputError naming ``field`` otherwise."""
    ok = {"user": _SYSTEM_USER.match(value), "address": _ADDRESS.match(value),
          "path": value.startswith("/") and value.isprintable() and value == value.strip()}
    if not ok[kind]:
        allowed = {"user": "a system user name (a-z, 0-9, _ -)",
                   "address": "an IP address or a host name",
                   "path": "an absolute path of printable characters"}[kind]
        raise InputError(field, value, f"give {allowed}")
    return value


class Tls(NamedTuple):
    """The files of a TLS listener (PEM): the server's certificate and key, and the CA that
    signed it (which the clients trust)."""

    certfile: str
    keyfile: str
    cafile: str


class Rule(NamedTuple):
    """One account: its user name and the topics it may publish and receive."""

    user: str
    write: tuple[str, ...]
    read: tuple[str, ...]


def rules(lift: str, bags) -> list[Rule]:
    """The accounts of the lift ``lift`` whose bags are ``bags`` (names), module table."""
    root = f"flexlift/{lift}"
    names = [str(b) for b in bags]
    for name in [lift, *names]:
        if not _USER.match(name):
            raise InputError("--lift" if name == lift else "bag name", name,
                             "use 1 to 64 letters, digits, _ . - (a topic level and a user name)")
    taken = {MASTER, RIG, HULL}
    if taken & set(names):
        raise InputError("bag name", sorted(taken & set(names))[0],
                         f"the names {', '.join(sorted(taken))} are the broker's roles")
    out = [Rule(MASTER, (f"{root}/command/#",), (f"{root}/sensor/#",)),
           Rule(RIG, (f"{root}/sensor/#",), (f"{root}/command/#",))]
    out += [Rule(b, (f"{root}/sensor/{b}/#",), (f"{root}/command/{b}/#",)) for b in names]
    out.append(Rule(HULL, (f"{root}/sensor/{HULL}/#",), ()))
    return out


def acl_text(accounts: list[Rule]) -> str:
    """Mosquitto's ``acl_file``: per user the topics it may write and read, nothing else."""
    lines = ["# flexlift: who may publish and receive what (docs/reference/live.md)", ""]
    for a in accounts:
        lines.append(f"user {a.user}")
        lines += [f"topic write {t}" for t in a.write]
        lines += [f"topic read {t}" for t in a.read]
        lines.append("")
    return "\n".join(lines)


def new_password() -> str:
    """A fresh random password (128 bits, URL-safe text)."""
    return secrets.token_urlsafe(16)


def password_hash(password: str, salt: bytes | None = None,
                  iterations: int = ITERATIONS) -> str:
    """``password`` as Mosquitto 2 stores it: ``$7$<iterations>$<salt>$<hash>`` (base64)."""
    salt = secrets.token_bytes(SALT_BYTES) if salt is None else salt
    digest = hashlib.pbkdf2_hmac("sha512", password.encode(), salt, iterations)
    b64 = base64.b64encode
    return f"${HASH_ID}${iterations}${b64(salt).decode()}${b64(digest).decode()}"


def passwd_text(passwords: dict[str, str]) -> str:
    """Mosquitto's ``password_file``: one ``user:hash`` a line."""
    return "".join(f"{user}:{password_hash(pw)}\n" for user, pw in passwords.items())


def mosquitto_conf(folder: str, port: int = 1883, listen: str | None = None,
                   network_port: int | None = None, tls: Tls | None = None,
                   run_as: str | None = None) -> str:
    """Mosquitto's configuration with the password file and ACL in ``folder`` (absolute).

    Parameters
    ----------
    folder : str
        The absolute folder that holds ``passwd`` and ``acl``.
    port : int
        The loopback listener's port (on 127.0.0.1: flexlift live on the broker's machine).
    listen : str or None
        An address the sensor nodes reach the broker on (``0.0.0.0``: every interface), or
        None for loopback only.
    network_port : int or None
        That listener's port (default 8883 with TLS, else 1883 + 1).
    tls : Tls or None
        The network listener's certificate, key and CA; None: plain MQTT (passwords sent
        in clear on that network).
    run_as : str or None
        The system user Mosquitto runs as once started as root (its ``user``; None: its
        default, ``mosquitto``): the user that must be able to read ``passwd`` and ``acl``.
    """
    check_setting("folder", folder, "path")
    if listen is not None:
        check_setting("--listen", listen, "address")
    if run_as is not None:
        check_setting("--run-as", run_as, "user")
    for name, path in zip(("--tls-cert", "--tls-key", "--tls-ca"), tls or ()):
        check_setting(name, path, "path")
    lines = ["# flexlift: the lift's broker (docs/reference/live.md#the-lifts-broker)",
             "per_listener_settings false", "allow_anonymous false",
             f"password_file {folder}/passwd", f"acl_file {folder}/acl",
             "persistence false", "max_queued_messages 100000",
             *([f"user {run_as}"] if run_as else []), "",
             f"listener {int(port)} 127.0.0.1"]
    if listen is not None:
        net = network_port or (8883 if tls else int(port) + 1)
        if int(net) == int(port):  # the two listeners would share it: Mosquitto stops
            raise InputError("--network-port", int(net), f"the loopback listener has port "
                             f"{int(port)} (--port): give another")
        lines += ["", f"listener {int(net)} {listen}"]
        if tls is not None:
            lines += [f"certfile {tls.certfile}", f"keyfile {tls.keyfile}",
                      f"cafile {tls.cafile}", "tls_version tlsv1.2"]
    return "\n".join(lines) + "\n"


#: the files :func:`write_broker` writes, and the folder of the clear passwords
CONF, ACL, PASSWD, PASSWORDS = "mosquitto.conf", "acl", "passwd", "passwords"


def write_broker(out, lift: str, bags, port: int = 1883, listen: str | None = None,
                 network_port: int | None = None, tls: Tls | None = None,
                 run_as: str | None = None) -> dict[str, str]:
    """Write the lift's broker into the output folder ``out`` (flexlift/output/folders.py):
    ``mosquitto.conf``, ``acl``, ``passwd`` (hashed) and ``passwords/<user>`` (one clear
    password a file, owner-only), new passwords every time. Returns user: password file.
    ``passwd`` is owner-only too: Mosquitto's ``run_as`` user must own it (``chown``)."""
    import os
    from pathlib import Path

    from flexlift.output.folders import output_folder
    from flexlift.plumbing.atomic import make_folders, write_text

    accounts = rules(lift, bags)
    final = Path(os.path.abspath(os.fspath(out)))
    passwords = {a.user: new_password() for a in accounts}
    with output_folder(out, "broker") as tmp:
        write_text(tmp / CONF, mosquitto_conf(str(final), port, listen, network_port, tls,
                                                 run_as))
        write_text(tmp / ACL, acl_text(accounts))
        write_text(tmp / PASSWD, passwd_text(passwords))
        os.chmod(tmp / PASSWD, 0o600)
        make_folders(tmp / PASSWORDS)  # journaled: flexlift's own on the next run
        os.chmod(tmp / PASSWORDS, 0o700)  # before any password is in it
        for user, password in passwords.items():
            write_text(tmp / PASSWORDS / user, password + "\n")
            os.chmod(tmp / PASSWORDS / user, 0o600)
    return {user: str(final / PASSWORDS / user) for user in passwords}


def read_password(path) -> str:
    """The password in the file ``path`` (its first line; at most 1 KiB); InputError naming
    ``--password-file`` if it cannot be read or is empty."""
    from flexlift.plumbing.reading import FileKind, decode, read_bytes

    kind = FileKind("password file", "a password", "text",
                    "give the file flexlift broker wrote in its passwords/ folder",
                    "a password file is one line", "save the password as UTF-8")
    text = decode(read_bytes(path, "--password-file", kind, limit=4096), "--password-file",
                  kind)
    password = text.splitlines()[0].strip() if text.strip() else ""
    if not password or len(password) > 1024:
        raise InputError("--password-file", str(path), "give a file whose first line is the "
                         "password (1 to 1024 characters)")
    return password
