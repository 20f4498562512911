"""Secrets at rest: passwords hashed with argon2id (argon2-cffi, the reference implementation's
bindings: a memory-hard hash a GPU cannot brute-force cheaply, with its parameters in the hash),
API tokens random and stored as their SHA-256 (a token is 256 random bits: a fast hash of it
reveals nothing, and the lookup by its digest takes the same time whatever the token)."""

from __future__ import annotations

import hashlib
import secrets

from argon2 import PasswordHasher
from argon2.exceptions import InvalidHashError, VerifyMismatchError

TOKEN_PREFIX = "scw_"  # tells a screwcal token apart in a log or a secrets scanner
_HASHER = PasswordHasher()  # argon2id, the library's current recommended parameters


def hash_password(password: str) -> str:
    """The argon2id hash of a password (salt and parameters inside)."""
    return _HASHER.hash(password)


def password_matches(stored: str, password: str) -> bool:
    """Whether `password` is the one `stored` hashes (constant time in the library)."""
    try:
        return _HASHER.verify(stored, password)
    except (VerifyMismatchError, InvalidHashError):
        return False


def new_token() -> str:
    """A fresh API token: shown once, never stored."""
    return TOKEN_PREFIX + secrets.token_urlsafe(32)


def token_digest(token: str) -> str:
    """What the store keeps of a token, and looks it up by."""
    return hashlib.sha256(token.encode()).hexdigest()
